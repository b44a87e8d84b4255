"""The GIL is released during library calls (ctypes.CDLL): a Python thread makes progress while
another thread combines; and combinations in several threads over shared layers give the
results of serial ones."""
import threading
import time

import numpy as np

import bsdfstack


def test_thread_runs_during_a_combination(pane, diffuser):
    layer = diffuser.resample(k=5)
    bsdfstack.combine([pane, layer, pane], k=5)     # warm up (glass layer made)
    stamps, stop = [], threading.Event()

    def ticker():
        while not stop.is_set():
            stamps.append(time.monotonic())

    t = threading.Thread(target=ticker)
    t.start()
    try:
        calls = []
        for _ in range(2):    # the library's own time, measured from inside the progress hook
            marks = []
            bsdfstack.combine([pane, layer, pane], k=5,
                              progress=lambda f, l: marks.append(time.monotonic()))
            calls.append(marks)
    finally:
        stop.set()
        t.join()
    # Between two progress reports the combining thread is inside the library and runs no Python
    # (all four components at k = 5: about half a second between the two reports).  Had it held
    # the GIL there, the ticker could run only while the report's own Python ran (a switch
    # interval or two, 5 ms each), so past 30 ms into that stretch its stamps fall in a few 10 ms
    # bins at most (2-3 measured with ctypes.PyDLL, which holds the GIL).  Released, the ticker
    # runs whenever it has a core (110-120 bins measured at load 6 on 2 cores); on a loaded
    # machine it may wait for one, but not all the time, so the test asks for stamps in at least
    # 20 distinct 10 ms bins of the longest stretch of either call, not for an even rhythm.
    bins_seen = []
    for marks in calls:
        gaps = np.diff(marks)
        i = int(np.argmax(gaps))
        a, b = marks[i] + 0.03, marks[i + 1]
        assert b - a > 0.1, "no stretch inside the library long enough to tell (%.3f s)" % (b - a)
        bins_seen.append(len({int((s - a) / 0.01) for s in stamps if a < s < b}))
    assert max(bins_seen) >= 20, \
        "the ticker ran in only %s of the 10 ms bins while the library ran" % bins_seen


def test_parallel_combinations_equal_serial(pane, diffuser):
    layer = diffuser.resample(k=3)
    glass2 = bsdfstack.glass("clear-3mm")
    stacks = [[pane, layer, pane], [glass2, layer], [layer, pane, glass2], [pane, layer.flip()]]
    serial = [bsdfstack.combine(s, k=3).matrix("Tf").copy() for s in stacks]
    results = [None] * 8

    def work(i):
        results[i] = bsdfstack.combine(stacks[i % 4], k=3).matrix("Tf")

    threads = [threading.Thread(target=work, args=(i,)) for i in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for i, r in enumerate(results):
        assert np.array_equal(r, serial[i % 4]), i
