"""Every error path raises bsdfstack.Error; where the library finds the error, the message is the
library's: the same text the program prints for the same mistake (its line is "bsdfstack SUB:
[WHAT: ]MESSAGE")."""
import os

import pytest

import bsdfstack
from conftest import SRCDIR, ref, run_cli


def cli_error(*args):
    err, status = run_cli(*args, check=False)[1:]
    assert status != 0 and err.count("\n") == 1
    return err.strip()


def test_missing_file(tmp_path):
    path = str(tmp_path / "nonexistent.xml")
    with pytest.raises(bsdfstack.Error) as e:
        bsdfstack.load(path)
    assert e.value.status == -4          # BST_EIO
    assert path in str(e.value) and str(e.value) in cli_error("info", path)


def test_malformed_file(tmp_path):
    path = tmp_path / "bad.xml"
    path.write_text("<WindowElement><Optical><Layer><WavelengthData>\n")
    with pytest.raises(bsdfstack.Error) as e:
        bsdfstack.load(path)
    assert e.value.status < 0 and str(e.value)
    assert str(e.value) in cli_error("info", path)


@pytest.mark.parametrize("name", ["mixed-klems-then-tree.xml", "mixed-tree-then-klems.xml"])
def test_mixed_kinds(name):
    """A file mixing Klems and tensor-tree blocks is refused (the interpreter died of SIGSEGV)."""
    path = os.path.join(SRCDIR, "tests", "fuzz", "regress", "xml", name)
    with pytest.raises(bsdfstack.Error) as e:
        bsdfstack.load(path)
    assert e.value.status == -5 and "a file holds one kind" in str(e.value)   # BST_EFORMAT
    assert str(e.value) in cli_error("info", path)


BAD_DIRECTIONS = [(float("nan"), 0), (0, float("nan")), (float("inf"), 0), (0, float("-inf")),
                  (90, 0), (-1, 0)]


@pytest.mark.parametrize("theta,phi", BAD_DIRECTIONS)
def test_direction_not_finite_or_out_of_range(pane, theta, phi):
    """Every call taking a direction refuses NaN, infinity and theta outside [0, 90) as the
    program's --incident does (NaN was patch 2^63, inf a value of some patch)."""
    s = bsdfstack.combine([pane], k=2)
    calls = [lambda: s.patch(theta, phi), lambda: s.hemispherical("Tf", theta, phi),
             lambda: s.hemispherical("Tf", [0, theta], [0, phi]),
             lambda: bsdfstack.columns([pane], [(theta, phi)], k=2),
             lambda: bsdfstack.compare(pane, pane, k=2, incident=[(theta, phi)])]
    for call in calls:
        with pytest.raises(bsdfstack.Error, match="0 <= theta < 90"):
            call()


def test_nul_in_a_name(tmp_path, pane):
    """A path or name with a NUL inside is refused, not cut at the NUL (load read a.xml for
    'a.xml\\0b')."""
    good = tmp_path / "a.xml"
    s = bsdfstack.combine([pane], k=1)
    s.write(good)
    for bad in (str(good) + "\0b", os.fsencode(good) + b"\0b"):
        with pytest.raises(bsdfstack.Error, match="NUL"):
            bsdfstack.load(bad)
        with pytest.raises(bsdfstack.Error, match="NUL"):
            s.write(bad)
    with pytest.raises(bsdfstack.Error, match="NUL"):
        bsdfstack.glass("clear-6mm\0x")
    with pytest.raises(bsdfstack.Error, match="NUL"):
        s.hemispherical("Tf", channel="Visible\0x")


@pytest.mark.parametrize("epoch", ["-1", "abc", "1e20", "253402300800", "\u00b2"])
def test_malformed_source_date_epoch(tmp_path, pane, monkeypatch, epoch):
    """A malformed SOURCE_DATE_EPOCH is an Error, with the program's words (it was ignored)."""
    s = bsdfstack.combine([pane], k=1)
    monkeypatch.setenv("SOURCE_DATE_EPOCH", epoch)
    with pytest.raises(bsdfstack.Error, match="SOURCE_DATE_EPOCH") as e:
        s.write(tmp_path / "a.xml")   # the program's words (tests/cli_hostile.sh checks its)
    assert not (tmp_path / "a.xml").exists()
    assert "is not a whole number of seconds since 1970" in str(e.value)


def test_unknown_glass():
    with pytest.raises(bsdfstack.Error) as e:
        bsdfstack.glass("no-such-pane")
    assert "no-such-pane" in str(e.value)
    assert str(e.value) in cli_error("combine", "-o", os.devnull, "glass:no-such-pane")
    with pytest.raises(bsdfstack.Error):   # a string spec in a stack goes the same way
        bsdfstack.combine(["glass:no-such-pane"])


def test_bad_inline_pane():
    with pytest.raises(bsdfstack.Error) as e:
        bsdfstack.glass("d=6mm,n=0.5,tn=0.9")
    assert str(e.value) in cli_error("glass", "d=6mm,n=0.5,tn=0.9")


@pytest.mark.parametrize("k", [0, 8, -1])
def test_k_out_of_range(pane, k):
    with pytest.raises(bsdfstack.Error) as e:
        bsdfstack.combine([pane], k=k)
    assert e.value.status == -1 and str(k) in str(e.value)   # BST_EINVAL, the library's words


def test_unknown_klems_basis(pane):
    with pytest.raises(bsdfstack.Error) as e:
        bsdfstack.combine([pane], klems="eighth")
    assert e.value.status < 0 and "eighth" in str(e.value)


def test_wrong_component_and_channel(pane, diffuser):
    s = bsdfstack.combine([pane, diffuser], k=2, only="Tf")
    for bad in ("Tx", "", "T", 7):
        with pytest.raises(bsdfstack.Error, match="unknown component"):
            s.matrix(bad)
    with pytest.raises(bsdfstack.Error, match="unknown component"):
        bsdfstack.combine([pane], k=2, only="Tf,Rx")
    with pytest.raises(bsdfstack.Error, match="component Rb is absent"):
        s.matrix("Rb")
    with pytest.raises(bsdfstack.Error, match="no channel 'Infrared'"):
        s.hemispherical("Tf", channel="Infrared")
    with pytest.raises(bsdfstack.Error, match="no channel"):
        bsdfstack.compare(pane, diffuser, k=2, channel="Solar")


def test_channel_the_file_lacks(pane, diffuser):
    with pytest.raises(bsdfstack.Error) as e:
        bsdfstack.combine([pane, diffuser], k=2, channels="Solar")
    assert "Solar" in str(e.value) and diffuser.path in str(e.value)
    with pytest.raises(bsdfstack.Error) as e:
        bsdfstack.load(diffuser.path, channels="Solar")
    assert str(e.value) in cli_error("combine", "--channels", "Solar", "-o", os.devnull,
                                     diffuser.path)


def test_bad_options(pane):
    with pytest.raises(bsdfstack.Error, match="precision"):
        bsdfstack.combine([pane], precision="half")
    with pytest.raises(bsdfstack.Error, match="exclude"):
        bsdfstack.combine([pane], k=2, klems="full")
    with pytest.raises(bsdfstack.Error, match="no layers"):
        bsdfstack.combine([])
    with pytest.raises(bsdfstack.Error, match="not a layer"):
        bsdfstack.combine([42])
    with pytest.raises(bsdfstack.Error, match="glass_rule"):
        bsdfstack.combine([pane], glass_rule="edge")


def test_basis_mismatch(pane, diffuser):
    inner = bsdfstack.combine([pane, diffuser], k=2)
    with pytest.raises(bsdfstack.Error, match="keeps its basis"):
        bsdfstack.combine([inner, pane], k=3)
    with pytest.raises(bsdfstack.Error, match="keeps its basis"):
        bsdfstack.compare(inner, diffuser, k=3)


def test_write_errors(tmp_path, pane):
    s = bsdfstack.combine([pane], k=1)
    with pytest.raises(bsdfstack.Error) as e:
        s.write(tmp_path)                  # a directory
    assert str(tmp_path) in str(e.value)
    with pytest.raises(bsdfstack.Error) as e:
        s.write(tmp_path / "no" / "such" / "dir.xml")
    assert e.value.status < 0
    assert not list(tmp_path.iterdir())    # nothing left behind


def test_strict_energy_error(pane):
    # strict: the blind's energy imbalance (T + R = 1.014 at 65 deg) is an error, else a warning
    blind = bsdfstack.load(ref("L_blind0_t4k5_klems.xml"))
    with pytest.warns(bsdfstack.LibraryWarning, match="T \\+ R"):
        bsdfstack.combine([pane, blind], klems="quarter")
    with pytest.raises(bsdfstack.Error, match="T \\+ R"):
        bsdfstack.combine([pane, blind], klems="quarter", strict=True)


def test_reader_warnings(tmp_path):
    # a TensorTree4 file's missing Tf comes from reciprocity silently (as the program); a
    # reflection taken as zero is a warning
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        bsdfstack.load(ref("L_blind0_t4k5.xml"), only="Tf")
    path = tmp_path / "tf.xml"
    bsdfstack.combine(["glass:clear-6mm"], klems="quarter", only="Tf").write(path)
    with pytest.warns(bsdfstack.LibraryWarning, match="Rf as zero"):
        bsdfstack.load(path)
