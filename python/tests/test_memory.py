"""No growth in memory over 1,000 small combinations: the resident set (VmRSS of
/proc/self/status) after 1,000 stacks at k = 3, each with a dense component (128 KiB of results
a stack, so a leaked system would add 125 MiB), its views and its absorptance taken, stays
within a few MiB of where it stood after a warm-up of 100."""
import gc

import pytest

import bsdfstack


def rss_kib():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    pytest.skip("no VmRSS in /proc/self/status")


def one(pane, layer):
    s = bsdfstack.combine([pane, layer, pane], k=3)
    v = s.matrix("Tf")
    t = s.hemispherical("Tf", 0, 0)
    f, b = s.absorptance()
    assert v.shape == (64, 64) and 0 < t < 1 and f.shape == (3, 64)


def test_no_growth_over_1000_combinations(pane, diffuser):
    layer = diffuser.resample(k=3)
    for _ in range(100):
        one(pane, layer)
    gc.collect()
    before = rss_kib()
    for _ in range(1000):
        one(pane, layer)
    gc.collect()
    grown = rss_kib() - before
    assert grown < 4096, "VmRSS grew by %d KiB over 1,000 combinations" % grown
