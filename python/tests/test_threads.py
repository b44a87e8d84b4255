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
    # the GIL there, the ticker could stamp nothing in that stretch past the first switch
    # interval (5 ms) after the report.  Released, the ticker stamps in it; on a loaded machine
    # it may wait for a core, but not for the whole stretch, so the test asks for one stamp in
    # the longest stretch of either call, not for an even rhythm.
    stamped = []
    for marks in calls:
        gaps = np.diff(marks)
        i = int(np.argmax(gaps))
        a, b = marks[i] + 0.02, marks[i + 1]
        assert b - a > 0.1, "no stretch inside the library long enough to tell (%.3f s)" % (b - a)
        stamped.append(sum(1 for s in stamps if a < s < b))
    assert max(stamped) > 0, "the ticker stamped nothing while the library ran (%s)" % stamped


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
