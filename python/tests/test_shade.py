"""Shades from their geometry in Python (venetian(), perforated(), woven()) and IGSDB shading
records (shade()): each gives exactly the layer of the equivalent spec, keyword arguments as the
spec's keys (lengths in metres or with units, (visible, solar) pairs), overrides replace the
record's values, stacks take them (objects and "shade:FILE" strings), errors are Error with the
library's one line."""
import json

import numpy as np
import pytest

import bsdfstack


def _record(path, subtype, optics, geometry, measured=None):
    """A made-up IGSDB v1 shading record (the shape test_shade.c and cli_shade.sh write)."""
    rec = {"product_id": 9100, "name": "made-up " + subtype, "type": "shading", "subtype": subtype,
           "manufacturer_name": "nobody",
           "composition": [{"child_product": {"product_id": 9001, "name": "m", "type": "material",
                                              "subtype": "monolithic",
                                              "measured_data": measured or {"thickness": 0.2},
                                              "spectral_data": optics},
                            "extra_data": {"geometry": geometry}}]}
    path.write_text(json.dumps(rec))
    return path


SLATS = {"dual_band_values": {"Rf_vis_diffuse": 0.7, "Rb_vis_diffuse": 0.55, "Rf_vis_specular": 0.05,
                              "Rb_vis_specular": 0.05, "Tf_vis_diffuse": 0.04, "Rf_sol_diffuse": 0.6,
                              "Rb_sol_diffuse": 0.5, "Rf_sol_specular": 0.1, "Rb_sol_specular": 0.1,
                              "Tf_sol_diffuse": 0.05}}
BLIND = {"slat_width": 16, "slat_spacing": 12, "slat_curvature": 0, "slat_tilt": 45,
         "number_segments": 5}
ROWS = {"spectral_data": [{"wavelength": 0.3, "T": 0.1, "Rf": 0.6, "Rb": 0.3},
                          {"wavelength": 2.5, "T": 0.1, "Rf": 0.6, "Rb": 0.3}]}


def same(a, b):
    """Every channel and component of two BSDFs equal to rounding."""
    assert a.channels == b.channels
    for ch in a.channels:
        for c in bsdfstack.COMPS:
            x, y = np.asarray(a.matrix(c, ch)), np.asarray(b.matrix(c, ch))
            assert np.abs(x - y).max() <= 1e-13 * np.abs(y).max(), (ch, c)


def test_venetian_record_is_its_spec(tmp_path):
    rec = _record(tmp_path / "blind.json", "venetian", SLATS, BLIND)
    s = bsdfstack.shade(rec)
    assert s.kind == "venetian"
    assert s.model == ("venetian:width=16mm,spacing=12mm,tilt=45,curvature=0mm,segments=5,"
                       "r-up=0.7/0.6,r-down=0.55/0.5,t=0.04/0.05,rs=0.05/0.1")
    v = bsdfstack.venetian(width=0.016, spacing="12mm", tilt=45, segments=5, r_up=(0.7, 0.6),
                           r_down=(0.55, 0.5), t=(0.04, 0.05), rs=(0.05, 0.1))
    same(s.layer(klems="quarter"), v.layer(klems="quarter"))
    # the record's tilt is a default
    s30 = bsdfstack.shade(rec, tilt=-30, segments=8, rs=0)
    v30 = bsdfstack.venetian(width=0.016, spacing=0.012, tilt=-30, segments=8, r_up=(0.7, 0.6),
                             r_down=(0.55, 0.5), t=(0.04, 0.05))
    same(s30.layer(klems="quarter"), v30.layer(klems="quarter"))


def test_screen_and_fabric_records(tmp_path):
    rec = _record(tmp_path / "screen.json", "perforated-screen", ROWS,
                  {"spacing_x": 5, "spacing_y": 5, "dimension_x": 1.5, "perforation_type": "Circular"},
                  {"thickness": 0.5})
    p = bsdfstack.perforated(x=0.005, y=0.005, radius="1.5mm", thickness=0.0005, rf=0.6, rb=0.3, t=0.1)
    same(bsdfstack.shade(rec).layer(k=3), p.layer(k=3))
    rec = _record(tmp_path / "fabric.json", "woven", ROWS,
                  {"thread_diameter": 0.5, "thread_spacing": 2, "shade_thickness": 0.6})
    w = bsdfstack.woven(diameter=0.0005, spacing=0.002, rf=0.6, rb=0.3, t=0.1, samples=8)
    same(bsdfstack.shade(rec, samples=8).layer(k=3), w.layer(k=3))


def test_window_mode(tmp_path):
    """rule="centre": WINDOW's models of screens and fabrics, also over a record.  WCE's
    RectangularPerforatedShade1.unit.cpp (TestSolarProperties) asserts T_dirhem 0.055556 at
    normal incidence in its quarter basis (within 1e-6); the rest of the light, reflected by the
    opaque sheet, is R = (1 - T) r."""
    p = bsdfstack.perforated(x="19.05mm", y="19.05mm", thickness="0.6mm", hole_x="3.175mm",
                             hole_y="6.35mm", t=0, r=0.7, rule="centre").layer(klems="quarter")
    t = p.hemispherical("Tf", 0, 0)
    assert abs(t - 0.055556) <= 1e-6
    assert abs(p.hemispherical("Rf", 0, 0) - (1 - t) * 0.7) <= 1e-12
    rec = _record(tmp_path / "fabric.json", "woven", ROWS,
                  {"thread_diameter": 0.5, "thread_spacing": 2, "shade_thickness": 0.6})
    w = bsdfstack.woven(diameter=0.0005, spacing=0.002, rf=0.6, rb=0.3, t=0.1, rule="centre")
    same(bsdfstack.shade(rec, rule="centre").layer(klems="quarter"), w.layer(klems="quarter"))
    with pytest.raises(bsdfstack.Error, match="rule"):
        bsdfstack.woven(diameter=0.0005, spacing=0.002, rule="middle").layer(klems="quarter")


def test_stacks_take_shades(tmp_path, pane):
    rec = _record(tmp_path / "blind.json", "venetian", SLATS, BLIND)
    a = bsdfstack.combine([pane, "shade:%s" % rec, pane], klems="quarter")
    b = bsdfstack.combine([pane, bsdfstack.venetian(width=0.016, spacing=0.012, tilt=45, segments=5,
                                                    r_up=(0.7, 0.6), r_down=(0.55, 0.5),
                                                    t=(0.04, 0.05), rs=(0.05, 0.1)), pane],
                          klems="quarter")
    same(a, b)
    # lossless mirror slats between nothing else: T + R = 1 for every patch (energy)
    m = bsdfstack.combine([bsdfstack.venetian(width="16mm", spacing="14.5mm", tilt=30, rs=1).flip()],
                          k=3)
    assert np.abs(m.hemispherical("Tf") + m.hemispherical("Rf") - 1).max() < 1e-9


def test_errors(tmp_path):
    rec = _record(tmp_path / "blind.json", "venetian", SLATS, BLIND)
    with pytest.raises(bsdfstack.Error, match="unknown key 'colour'"):
        bsdfstack.shade(rec, colour="red")
    with pytest.raises(bsdfstack.Error, match="unknown key 'colour'"):
        bsdfstack.venetian(width=0.016, spacing=0.012, colour="red")
    with pytest.raises(bsdfstack.Error, match="spacing missing"):
        bsdfstack.venetian(width=0.016)
    with pytest.raises(bsdfstack.Error, match="r: give one value or a"):
        bsdfstack.venetian(width=0.016, spacing=0.012, r=(0.1, 0.2, 0.3))
    pane = tmp_path / "pane.json"
    pane.write_text('{"product_id": 1, "type": "glazing", "subtype": "monolithic"}')
    with pytest.raises(bsdfstack.Error, match="not a shading product"):
        bsdfstack.shade(pane)
    with pytest.raises(bsdfstack.Error, match="name it shade:"):
        bsdfstack.glass(str(rec))
