"""The package's own promises: numpy views on the library's buffers and their lifetime, the index
convention (column = incident patch), closed forms (two clear panes), energy balance, write and
read back, layers reused across stacks, progress, and GA / LA against eq. 7 and 8 computed here
from the matrices."""
import gc
import math

import numpy as np
import pytest

import bsdfstack
from conftest import ref, rel_max


def test_dense_matrix_is_a_view_that_keeps_its_owner(pane, diffuser):
    s = bsdfstack.combine([pane, diffuser, pane], k=3)
    assert s.structure("Tf") == "dense"
    a, b = s.matrix("Tf"), s.matrix("Tf")
    assert np.shares_memory(a, b)          # no copy: both are the library's buffer
    assert a.shape == (64, 64) and a.dtype == np.float64 and a.flags.f_contiguous
    assert not a.flags.writeable
    copy = np.array(a)
    base = a.base
    while not isinstance(base, bsdfstack.BSDF) and hasattr(base, "owner"):
        base = base.owner
    assert base is s
    del s, b, base
    gc.collect()
    junk = [bsdfstack.combine([pane, diffuser], k=3).matrix("Rb") for _ in range(3)]  # reuse heap
    assert np.array_equal(a, copy)         # still the same buffer, still alive
    del junk


def test_single_precision_view_is_float32(pane, diffuser):
    s = bsdfstack.combine([pane, diffuser], k=2, precision="single")
    m = s.matrix("Tf")
    assert m.dtype == np.float32 and m.shape == (16, 16)
    d = bsdfstack.combine([pane, diffuser], k=2)
    assert rel_max(m, d.matrix("Tf")) < 1e-5


def test_column_is_the_incident_patch():
    # an asymmetric blind: hemispherical T of incident patch j is sum_i Lambda_i M(i, j) (the
    # column), not the row
    b = bsdfstack.load(ref("L_blind45_t4k5_klems.xml"))
    m, lam = np.array(b.matrix("Tf")), b.lambda_()
    h = b.hemispherical("Tf")
    assert np.allclose(lam @ m, h, rtol=1e-12, atol=1e-14)
    assert np.abs(m @ lam - h).max() > 1e-2
    # and hemispherical(theta, phi) is that of the patch of the propagation direction
    j = b.patch(45, 90)
    assert b.hemispherical("Tf", 45, 90) == h[j]
    th, ph = b.directions()
    assert abs(th[j] - 45) < 8 and abs(ph[j] - 90) < 13


def test_two_panes_closed_form():
    # diagonal panes: per patch T = T1 T2 / (1 - Rb1 Rf2), R = Rf1 + T1 Tb1 Rf2 / (1 - Rb1 Rf2)
    g1, g2 = bsdfstack.glass("clear-6mm"), bsdfstack.glass("d=4mm,n=1.6,tn=0.8")
    s = bsdfstack.combine([g1, g2], k=4, per_channel=True)
    a, b = g1.layer(k=4), g2.layer(k=4)
    assert s.structure("Tf") == "diagonal" and a.structure("Tf") == "diagonal"
    m = s.matrix("Tf")
    assert np.count_nonzero(m - np.diag(np.diag(m))) == 0
    for ch in s.channels:
        h = {c: (a.hemispherical(c, channel=ch), b.hemispherical(c, channel=ch))
             for c in ("Tf", "Rf", "Tb", "Rb")}
        den = 1 - h["Rb"][0] * h["Rf"][1]
        assert np.allclose(s.hemispherical("Tf", channel=ch), h["Tf"][0] * h["Tf"][1] / den,
                           rtol=1e-12, atol=0)
        assert np.allclose(s.hemispherical("Rf", channel=ch),
                           h["Rf"][0] + h["Tf"][0] * h["Tb"][0] * h["Rf"][1] / den,
                           rtol=1e-12, atol=0)


def test_diagonal_copy_and_energy_balance(pane, diffuser):
    g = pane.layer(k=3)
    d = g.matrix("Tf")
    assert np.allclose(np.diag(d) * g.lambda_(), g.hemispherical("Tf"), rtol=1e-14)
    s = bsdfstack.combine([pane, diffuser, pane], k=3, absorptance=True)
    front, back = s.absorptance()
    assert front.shape == (3, 64) and (front >= 0).all()
    assert np.abs(s.hemispherical("Tf") + s.hemispherical("Rf") + front.sum(0) - 1).max() < 1e-9
    assert np.abs(s.hemispherical("Tb") + s.hemispherical("Rb") + back.sum(0) - 1).max() < 1e-9


def test_spectral_absorptance_balance():
    s = bsdfstack.combine(["glass:nfrc-102", "glass:nfrc-103"], k=2)
    assert s.spectral
    for ch in s.channels:
        f, b = s.absorptance(ch)
        assert np.abs(s.hemispherical("Tf", channel=ch) + s.hemispherical("Rf", channel=ch)
                      + f.sum(0) - 1).max() < 1e-9


def test_write_and_read_back(tmp_path, pane, diffuser):
    s = bsdfstack.combine([pane, diffuser, pane], k=3)
    s.write(tmp_path / "s.xml", reduce=None)
    back = bsdfstack.load(tmp_path / "s.xml")
    for c in ("Tf", "Rf", "Tb", "Rb"):
        assert rel_max(back.matrix(c), s.matrix(c)) < 2e-7
    k = bsdfstack.combine([pane, diffuser], klems="half")
    k.write(tmp_path / "k.xml")
    assert rel_max(bsdfstack.load(tmp_path / "k.xml").matrix("Rb"), k.matrix("Rb")) < 1e-15


def test_reduced_write_keeps_hemispherical_values(tmp_path, pane, diffuser):
    """The default reduction keeps every incident patch's T and R within 0.002 of the system
    (and reduce_tol within that tolerance); the percentile alone (reduce_tol=inf) does not."""
    s = bsdfstack.combine([pane, diffuser, pane], k=4)
    worst = {}
    for tol in (None, 0.005, float("inf")):
        path = tmp_path / ("r%s.xml" % tol)
        s.write(path, reduce_tol=tol)
        back = bsdfstack.load(path)
        worst[tol] = max(np.abs(back.hemispherical(c) - s.hemispherical(c)).max()
                         for c in ("Tf", "Rf", "Tb", "Rb"))
    assert worst[None] <= 0.002 + 1e-9
    assert worst[0.005] <= 0.005 + 1e-9
    assert worst[float("inf")] > 0.01
    with pytest.raises(bsdfstack.Error, match="reduce_tol"):
        s.write(tmp_path / "bad.xml", reduce_tol=-1)
    assert not (tmp_path / "bad.xml").exists()


def test_layers_load_once_and_serve_many_stacks(pane, diffuser):
    a = bsdfstack.combine([pane, diffuser, pane], k=3)
    b = bsdfstack.combine([pane, diffuser], k=2)
    c = bsdfstack.combine([pane, diffuser, pane], k=3)
    assert np.array_equal(a.matrix("Tf"), c.matrix("Tf"))
    assert b.size == 16
    # the layer over k = 3 was made once: the same object serves both stacks
    assert a._held[1] is c._held[1] and a._held[0] is a._held[2]


def test_combined_stack_enters_a_stack_over_its_basis(pane, diffuser):
    inner = bsdfstack.combine([pane, diffuser], k=2)
    whole = bsdfstack.combine([inner, pane], k=2)
    direct = bsdfstack.combine([pane, diffuser, pane], k=2)
    assert rel_max(whole.matrix("Tf"), direct.matrix("Tf")) < 1e-12


def test_progress_callback(pane, diffuser):
    seen = []
    bsdfstack.combine([pane, diffuser, pane], k=3, progress=lambda f, l: seen.append((f, l)))
    assert seen and all(0 <= f <= 1 and isinstance(l, str) for f, l in seen)

    def boom(f, l):
        raise KeyError("stop")
    with pytest.raises(KeyError):
        bsdfstack.combine([pane, diffuser, pane], k=3, progress=boom)


def test_accordance_is_eq_7_and_8(diffuser):
    klems = bsdfstack.load(ref("L_diffuser_t3k5_klems.xml"))
    r = bsdfstack.compare(diffuser, klems, k=3, incident=[(45, 90), (0, 0), (60, 0)], only="Tf,Rb")
    a, b = diffuser.resample(k=3), klems.resample(k=3)
    lam = a.lambda_()
    assert r.components == ("Tf", "Rb")
    for c in r.components:
        for q, j in enumerate(r.patches):
            x, y = np.array(a.matrix(c))[:, j], np.array(b.matrix(c))[:, j]
            ga = 100 * (1 - (lam * (x - y) ** 2).sum() / (lam * (x + y) ** 2).sum())
            s = x + y
            la = np.where(s > 0, 100 * (1 - np.abs(x - y) / np.where(s > 0, s, 1)), 100)
            assert abs(r.ga[c][q] - ga) < 1e-9
            assert np.allclose(r.la[c][q], la, rtol=0, atol=1e-9)
            assert r.ga_all[c][j] == r.ga[c][q]
        assert 90 < r.ga[c].min() < 100   # two genuinely different files


@pytest.mark.parametrize("back", [False, True])
def test_columns_equal_the_whole_systems(pane, diffuser, back):
    """columns() iterates a few incident directions; they equal those columns of combine()'s
    system (to 1e-8 of each column's largest value), front and back, in every channel."""
    stack = [pane, diffuser, pane]
    full = bsdfstack.combine(stack, k=3)
    dirs = [(0, 0), (30, 270), (62, 45)]
    c = bsdfstack.columns(stack, dirs, k=3, back=back)
    assert c.channels == tuple(full.channels) and c.iterations >= 2 and c.residual <= 1e-12
    assert list(c.patches) == [full.patch(t, p) for t, p in dirs]
    for ch in c.channels:
        for got, comp in ((c.t[ch], "Tb" if back else "Tf"), (c.r[ch], "Rb" if back else "Rf")):
            m = full.matrix(comp, ch)
            for q, j in enumerate(c.patches):
                assert rel_max(got[:, q], m[:, j]) < 1e-8


def test_spectral_columns_follow_the_spectral_system(tmp_path):
    """A spectral stack with a band-value layer is iterated per wavelength as combine() combines
    it, not by band values."""
    band = tmp_path / "band.xml"
    bsdfstack.glass("clear-6mm").layer(k=3).write(str(band), reduce=-1)
    stack = ["glass:nfrc-102", str(band), "glass:nfrc-103"]
    full = bsdfstack.combine(stack, k=3)
    bands = bsdfstack.combine(stack, k=3, per_channel=True)
    c = bsdfstack.columns(stack, [(0, 0), (40, 120)], k=3)
    assert full.spectral and c.spectral and "Solar" in c.channels
    j = c.patches[1]
    assert rel_max(c.t["Solar"][:, 1], full.matrix("Tf", "Solar")[:, j]) < 1e-8
    assert rel_max(c.t["Solar"][:, 1], bands.matrix("Tf", "Solar")[:, j]) > 1e-3
    with pytest.raises(bsdfstack.Error, match="no incident directions"):
        bsdfstack.columns(stack, [], k=3)


def test_glass_model_source_metadata(tmp_path):
    """A pane's model, source and metadata as `bsdfstack glass` prints them: the catalogue's
    coated pane, model= overriding it, and an Optics file whose type picks the model."""
    lowe = bsdfstack.glass("lowe-6mm")
    assert (lowe.model, lowe.source) == ("coated", "catalogue")
    assert (lowe.metadata["model_from"], lowe.metadata["type"]) == ("type", "Coated")
    assert lowe.metadata["path"].endswith("lowe-6mm.glass")
    assert bsdfstack.glass("lowe-6mm,model=uncoated").model == "uncoated"
    assert bsdfstack.glass("lowe-6mm,model=uncoated").metadata["model_from"] == "spec"
    inline = bsdfstack.glass("t0=0.8,r0=0.08")
    assert (inline.model, inline.source, inline.metadata) == ("uncoated", "inline",
                                                              {"source": "inline", "model_from": "default"})
    f = tmp_path / "COATED_4.DAT"
    f.write_text("{ Units, Wavelength Units } SI Nanometers\n{ Thickness } 4.1\n"
                 "{ Product Name: Made-up low-e }\n{ NFRC ID: 9999 }\n{ Type: Coated }\n"
                 "{ Coated Side: Back }\n{ Emissivity, front back } Emis= 0.84 0.04\n"
                 "300 0.1 0.2 0.3\n400 0.7 0.1 0.1\n800 0.6 0.2 0.3\n2500 0.1 0.4 0.5\n")
    g = bsdfstack.glass(str(f))
    assert (g.model, g.source) == ("coated", "optics")
    assert g.metadata == {"source": "optics", "path": str(f), "type": "Coated", "model_from": "type",
                          "product_name": "Made-up low-e", "coated_side": "Back",
                          "wavelength_units": "Nanometers", "nfrc_id": 9999, "thickness_mm": 4.1,
                          "emissivity_front": 0.84, "emissivity_back": 0.04}


def test_glass_visible_only_data(tmp_path):
    """Spectral data that cover only the visible: refused for Visible and Solar (the default),
    taken when the channels asked for are bands they cover (bst_glass_parse_bands)."""
    f = tmp_path / "vis.tsv"
    f.write_text("".join("%.2f 0.85 0.84 0.08 0.09\n" % (0.38 + 0.01 * i) for i in range(41)))
    with pytest.raises(bsdfstack.Error, match="the Solar band needs 0.3..2.5 um"):
        bsdfstack.glass(str(f))
    g = bsdfstack.glass(str(f), channels=["Visible"])
    assert g.channels == ("Visible",)
    with pytest.raises(bsdfstack.Error, match="the Solar band needs"):
        bsdfstack.glass(str(f), channels=["Visible", "Solar"])


def test_glass_many_rows_grouped(tmp_path):
    """A pane of 6000 rows: its Solar layer sums 5000 groups of adjacent wavelengths, with a
    LibraryWarning that says so; ",rows=all" sums each, without it, and the two layers' patch
    values (Lambda x value) agree within 1e-8 (bsdfstack-glass(5))."""
    import warnings as w
    f = tmp_path / "many.txt"
    f.write_text("".join("%.8f %.6f %.6f %.6f %.6f\n" % (0.3 + 2.2 * i / 5999, t, t, r, r + 0.01)
                         for i in range(6000)
                         for t, r in [(0.45 + 0.25 * math.sin(15.4 * i / 5999),
                                       0.07 + 0.02 * math.cos(11.0 * i / 5999))]))
    with pytest.warns(bsdfstack.LibraryWarning, match="5000 groups of adjacent wavelengths"):
        grouped = bsdfstack.glass(str(f)).layer(k=2, channels=["Solar"])
    with w.catch_warnings():
        w.simplefilter("error")
        every = bsdfstack.glass(str(f) + ",rows=all").layer(k=2, channels=["Solar"])
    lam = grouped.lambda_()
    for c in ("Tf", "Rf", "Tb", "Rb"):
        d = np.abs(np.diag(np.asarray(grouped.matrix(c))) - np.diag(np.asarray(every.matrix(c)))) * lam
        assert 0 < d.max() <= 1e-8, (c, d.max())


def test_rank3_native_is_factored_at_its_own_order():
    """load(rank3="native"): the depth-5 diffuser at k = 6 is held factored, and every fine
    incident patch has the hemispherical T and R of the order-5 patch holding it (P M_5 P^T
    spreads each order-5 value over four cells of a quarter of its solid angle)."""
    native = bsdfstack.load(ref("L_diffuser_t3k5.xml"), rank3="native")
    exact5 = bsdfstack.load(ref("L_diffuser_t3k5.xml")).resample(k=5)
    fine = native.resample(k=6)
    assert fine.structure("Tf") == "factored"
    for comp in ("Tf", "Rf", "Tb", "Rb"):
        for theta, phi in ((0, 0), (30, 45), (60, 200)):
            assert abs(fine.hemispherical(comp, theta, phi) -
                       exact5.hemispherical(comp, theta, phi)) < 1e-12
    with pytest.raises(ValueError):
        bsdfstack.load(ref("L_diffuser_t3k5.xml"), rank3="coarse")


def _import_in_child(coretype):
    """Import the package in a fresh python3 (OPENBLAS_CORETYPE as given, None: unset): its
    blas_kernels() and what it printed on standard error."""
    import os
    import subprocess
    import sys
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    if coretype:
        env["OPENBLAS_CORETYPE"] = coretype
    p = subprocess.run([sys.executable, "-c", "import bsdfstack; print(bsdfstack.blas_kernels())"],
                       capture_output=True, text=True, env=env, check=True)
    return p.stdout.strip(), p.stderr


def test_blas_kernels_advice():
    # OpenBLAS's pick without AVX2 on a CPU with AVX2 and FMA (0.3.21's Prescott on an AVX-512
    # Xeon) is told on import, naming the setting; a user's setting is kept and told nothing
    core, err = _import_in_child(None)
    if core == "None":
        pytest.skip("the library runs another BLAS than OpenBLAS")
    try:
        with open("/proc/cpuinfo") as f:
            flags = set(next((line.split(":", 1)[1].split() for line in f
                              if line.startswith("flags")), []))
    except OSError:
        flags = set()
    old = core.lower() in {"prescott", "core2", "penryn", "dunnington", "nehalem", "atom",
                           "sandybridge"}
    if old and {"avx2", "fma"} <= flags:
        assert "set OPENBLAS_CORETYPE=" in err, err
        want = "SkylakeX" if {"avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl"} <= flags \
            else "Haswell"
        assert "OPENBLAS_CORETYPE=%s " % want in err, err
        chosen, err2 = _import_in_child(want)
        assert chosen == want and "OPENBLAS_CORETYPE" not in err2, (chosen, err2)
    else:
        assert "OPENBLAS_CORETYPE" not in err, err
    kept, err3 = _import_in_child(core)
    assert kept == core and "OPENBLAS_CORETYPE" not in err3, (kept, err3)
