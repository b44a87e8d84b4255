"""The package's results against the program's on the same stacks: `bsdfstack combine` (its file
read back), `combine --absorptance`, `info` and `compare`, run here on fixed inputs."""
import re

import numpy as np
import pytest

import bsdfstack
from conftest import ref, rel_max, run_cli

COMPS = ("Tf", "Rf", "Tb", "Rb")


def assert_same_system(py, path, tol):
    """Every component of every channel of py equals the program's file at path within tol
    (relative to the component's largest value)."""
    cli = bsdfstack.load(path)
    assert cli.k == py.k and cli.size == py.size
    assert sorted(cli.channels) == sorted(py.channels)
    for ch in py.channels:
        for c in COMPS:
            err = rel_max(py.matrix(c, ch), cli.matrix(c, ch))
            assert err <= tol, (c, ch, err)


def test_combine_tree_equals_program(tmp_path, pane, diffuser):
    # unreduced tree: the file holds float values, exact to float rounding
    out = tmp_path / "cli.xml"
    run_cli("combine", "-k", 3, "--no-reduce", "-o", out, "glass:clear-6mm", diffuser.path,
            "glass:clear-6mm")
    s = bsdfstack.combine([pane, diffuser, pane], k=3)
    assert_same_system(s, out, 2e-7)


def test_combine_klems_equals_program(tmp_path, pane):
    # a Klems file holds doubles: equal to rounding; a reversed layer (^) and flip() agree
    blind = ref("L_blind45_t4k5_klems.xml")
    out = tmp_path / "cli.xml"
    run_cli("combine", "--klems=quarter", "-o", out, "glass:clear-6mm", blind + "^")
    s = bsdfstack.combine([pane, bsdfstack.load(blind).flip()], klems="quarter")
    assert_same_system(s, out, 1e-12)
    # and the blind really is asymmetric: unreversed it differs
    s2 = bsdfstack.combine([pane, blind], klems="quarter")
    assert rel_max(s2.matrix("Tf"), s.matrix("Tf")) > 1e-3


def test_combine_single_precision_equals_program(tmp_path, pane, diffuser):
    out = tmp_path / "cli.xml"
    run_cli("combine", "-k", 3, "--precision", "single", "--only", "Tf,Rb", "--no-reduce", "-o",
            out, "glass:clear-6mm", diffuser.path, "glass:clear-6mm")
    s = bsdfstack.combine([pane, diffuser, pane], k=3, only="Tf,Rb", precision="single")
    assert s.components == ("Tf", "Rb")
    assert s.matrix("Tf").dtype == np.float32
    cli = bsdfstack.load(out, only="Tf,Rb")
    for c in ("Tf", "Rb"):
        assert rel_max(s.matrix(c), cli.matrix(c)) <= 2e-7, c


def test_spectral_panes_equal_program(tmp_path):
    # two spectral panes: per wavelength, averaged per band (the program's plan and numbers)
    out = tmp_path / "cli.xml"
    run_cli("combine", "--klems=quarter", "-o", out, "glass:nfrc-102", "glass:nfrc-103")
    s = bsdfstack.combine(["glass:nfrc-102", "glass:nfrc-103"], klems="quarter")
    assert s.spectral and s.plan.startswith("combined wavelength by wavelength")
    assert_same_system(s, out, 1e-12)
    # and per channel, as --per-channel, it is another (band-value) result
    out2 = tmp_path / "cli2.xml"
    run_cli("combine", "--klems=quarter", "--per-channel", "-o", out2, "glass:nfrc-102",
            "glass:nfrc-103")
    s2 = bsdfstack.combine(["glass:nfrc-102", "glass:nfrc-103"], klems="quarter", per_channel=True)
    assert not s2.spectral
    assert_same_system(s2, out2, 1e-12)
    assert rel_max(s.matrix("Tf", "Solar"), s2.matrix("Tf", "Solar")) > 1e-3


def test_absorptance_equals_program(tmp_path, pane, diffuser):
    tsv = tmp_path / "abs.tsv"
    run_cli("combine", "-k", 2, "--absorptance", tsv, "-o", tmp_path / "x.xml", "glass:clear-6mm",
            diffuser.path, "glass:clear-6mm")
    s = bsdfstack.combine([pane, diffuser, pane], k=2)
    front, back = s.absorptance("Visible")
    rows = [l.split("\t") for l in tsv.read_text().splitlines()[1:]]
    n = 0
    for r in rows:
        side, j = r[1], int(r[2])
        a = (front if side == "front" else back)[:, j]
        assert np.allclose(a, [float(x) for x in r[5:8]], rtol=0, atol=6e-9), (side, j)
        n += 1
    assert n == 2 * 16


@pytest.mark.parametrize("name", ["L_diffuser_t3k5_klems.xml", "L_blind0_t4k5_klems.xml"])
def test_hemispherical_equals_info(name):
    path = ref(name)
    out = run_cli("info", path)[0]
    b = bsdfstack.load(path)
    rows = re.findall(r"^\s*(\d+)\s+(\d+)\s+([-\d.]+)\s+([-\d.]+)\s+([-\d.]+)\s+([-\d.]+)\s*$",
                      out, re.M)
    assert len(rows) == 11
    for r in rows:
        t, p = float(r[0]), float(r[1])
        for c, v in zip(COMPS, r[2:]):
            assert abs(b.hemispherical(c, t, p) - float(v)) <= 5.01e-5, (c, t, p)


def test_compare_equals_program(diffuser):
    klems = ref("L_diffuser_t3k5_klems.xml")
    out = run_cli("compare", "-k", 3, "--incident", "45,90", "--incident", "0,0",
                  diffuser.path, klems)[0]
    r = bsdfstack.compare(diffuser, bsdfstack.load(klems), k=3, incident=[(45, 90), (0, 0)])
    assert r.components == COMPS and r.patches == [38, 36]
    blocks = re.split(r"^(Tf|Rf|Tb|Rb) \(", out, flags=re.M)[1:]
    assert len(blocks) == 8
    for comp, text in zip(blocks[0::2], blocks[1::2]):
        rows = re.findall(r"^\s+([\d.]+)\s+([\d.]+)\s+(\d+)\s+([\d.]+)\s+([\d.]+)\s+([\d.]+)\s+"
                          r"([\d.]+)$", text, re.M)
        assert len(rows) == 2
        for q, row in enumerate(rows):
            assert int(row[2]) == r.patches[q]
            assert abs(r.ga[comp][q] - float(row[3])) <= 5.01e-4
            assert abs(r.fa[comp][q] - float(row[4])) <= 5.01e-3
            assert abs(r.hem_a[comp][q] - float(row[5])) <= 5.01e-5
            assert abs(r.hem_b[comp][q] - float(row[6])) <= 5.01e-5
        mean = re.search(r"GA mean ([\d.]+), least ([\d.]+)", text)
        assert abs(r.ga_all[comp].mean() - float(mean.group(1))) <= 5.01e-4
        assert abs(r.ga_all[comp].min() - float(mean.group(2))) <= 5.01e-4
