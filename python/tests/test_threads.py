"""The GIL is released during library calls (ctypes.CDLL): a Python thread makes progress while
another thread combines; and combinations in several threads over shared layers give the
results of serial ones."""
import threading
import time

import numpy as np

import bsdfstack


def test_thread_runs_during_a_combination(pane, diffuser):
    layer = diffuser.resample(k=5)
    bsdfstack.combine([pane, layer, pane], k=5, only="Tf")     # warm up (glass layer made)
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
            bsdfstack.combine([pane, layer, pane], k=5, only="Tf",
                              progress=lambda f, l: marks.append(time.monotonic()))
            calls.append((marks[0], marks[-1]))
    finally:
        stop.set()
        t.join()
    # between the first and last progress report the combining thread is inside the library
    # (a k = 5 solve, most of a second); had it held the GIL there, the ticker would have
    # stamped nothing for about that long (it may run a switch interval, 5 ms, inside a
    # callback).  Released, the ticker's longest pause is scheduling noise.
    for start, end in calls:
        assert end - start > 0.1, "combination too short to tell"
        inside = [start] + [s for s in stamps if start < s < end] + [end]
        pause = max(np.diff(inside))
        assert pause < 0.5 * (end - start), \
            "the ticker paused %.3f s of the library's %.3f s" % (pause, end - start)


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
