#!/usr/bin/env python3
"""param_study.py - a parameter study in Python: three panes x the reference shades x k = 4, 5.

Each stack is pane + shade + pane (exterior first).  Every layer is read once and serves all the
stacks it enters; each stack is combined by libbsdfstack through the bsdfstack package.  Writes

  OUT/param_study.csv  one row per stack: the directional-hemispherical front transmittance at
                       incidence theta = 0, 30, 60 degrees (light propagating towards +Y), the
                       front reflectance and the shade's absorptance at normal incidence, and the
                       seconds the combination took
  OUT/param_study.svg  normal-incidence transmittance per stack, k = 4 beside k = 5

Run from the build tree (BUILDDIR = where make ran):

  PYTHONPATH=BUILDDIR/python python3 examples/python/param_study.py [--refdir DIR] [--out DIR]

--refdir defaults to ../shared/reference beside the checkout ($BST_REFDIR if set), --out to
examples/out/python.  The glass catalogue is the library's (or $BSDFSTACK_GLASS_DIR).
"""
import argparse
import csv
import os
import sys
import time

import bsdfstack

HERE = os.path.dirname(os.path.abspath(__file__))
TOP = os.path.dirname(os.path.dirname(HERE))

PANES = ["clear-6mm", "lowiron-6mm", "clear-3mm"]
SHADES = ["L_blind0_t4k5.xml", "L_blind45_t4k5.xml", "L_diffuser_t3k5.xml"]
ORDERS = [4, 5]
THETAS = [0, 30, 60]


def study(refdir, log):
    """Rows of the study, one per (pane, shade, k)."""
    panes = {p: bsdfstack.glass(p) for p in PANES}
    rows = []
    for shade_name in SHADES:
        t0 = time.perf_counter()
        shade = bsdfstack.load(os.path.join(refdir, shade_name))
        log("read %s (%s, k = %d) in %.1f s" % (shade_name, shade.file_kind, shade.order,
                                                 time.perf_counter() - t0))
        for pane_name, pane in panes.items():
            for k in ORDERS:
                t0 = time.perf_counter()
                s = bsdfstack.combine([pane, shade, pane], k=k, channels="Visible")
                secs = time.perf_counter() - t0
                front, _ = s.absorptance()
                j = s.patch(0, 0)
                row = {"pane": pane_name, "shade": shade_name[:-4], "k": k, "patches": s.size}
                for t in THETAS:
                    row["T_front_%d" % t] = s.hemispherical("Tf", t, 90)
                row["R_front_0"] = s.hemispherical("Rf", 0, 0)
                row["A_shade_0"] = front[1, j]
                row["seconds"] = secs
                rows.append(row)
                log("%-12s %-16s k = %d: T(0) %.4f  R(0) %.4f  A_shade(0) %.4f  (%.2f s)" % (
                    pane_name, shade_name[:-4], k, row["T_front_0"], row["R_front_0"],
                    row["A_shade_0"], secs))
        shade.forget()  # its layers over k = 4 and 5 are no longer needed
    return rows


def write_csv(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: ("%.6f" % v if isinstance(v, float) else v) for k, v in r.items()})


def pale(colour):
    """colour ("#rrggbb") mixed half and half with white."""
    rgb = [int(colour[i:i + 2], 16) for i in (1, 3, 5)]
    return "#" + "".join("%02x" % ((c + 255) // 2) for c in rgb)


def write_svg(path, rows):
    """A grouped bar chart of T_front_0: one group per shade, one pair of bars (k = 4, k = 5)
    per pane; plain SVG, no plotting library."""
    colours = ["#1b9e77", "#d95f02", "#7570b3"]
    width, height, left, bottom, top = 720, 420, 60, 60, 40
    plot_h = height - bottom - top
    ymax = 1.0
    shades = [s[:-4] for s in SHADES]
    group_w = (width - left - 20) / len(shades)
    bar_w = group_w / (len(PANES) * len(ORDERS) + 2)
    out = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" '
           'font-family="sans-serif" font-size="12">' % (width, height),
           '<rect width="100%" height="100%" fill="white"/>',
           '<text x="%d" y="22" font-size="14">Normal-incidence transmittance, pane + shade + '
           'pane (Visible); pale: k = 4, dark: k = 5</text>' % left]
    for i in range(6):  # axis and grid
        v = ymax * i / 5
        y = top + plot_h * (1 - v / ymax)
        out.append('<line x1="%d" y1="%.1f" x2="%d" y2="%.1f" stroke="#ddd"/>' % (left, y, width - 20, y))
        out.append('<text x="%d" y="%.1f" text-anchor="end">%.2f</text>' % (left - 6, y + 4, v))
    for g, shade in enumerate(shades):
        x0 = left + g * group_w + bar_w
        for p, pane in enumerate(PANES):
            for o, k in enumerate(ORDERS):
                r = next(r for r in rows if r["shade"] == shade and r["pane"] == pane and r["k"] == k)
                h = plot_h * r["T_front_0"] / ymax
                x = x0 + (p * len(ORDERS) + o) * bar_w
                out.append('<rect x="%.1f" y="%.1f" width="%.1f" height="%.1f" fill="%s">'
                           '<title>%s, %s, k = %d: %.4f</title></rect>' % (
                               x, top + plot_h - h, bar_w * 0.9, h,
                               pale(colours[p]) if o == 0 else colours[p], pane, shade, k,
                               r["T_front_0"]))
        out.append('<text x="%.1f" y="%d" text-anchor="middle">%s</text>' % (
            left + (g + 0.5) * group_w, height - bottom + 20, shade))
    for p, pane in enumerate(PANES):  # legend
        x = left + p * 160
        out.append('<rect x="%d" y="%d" width="12" height="12" fill="%s"/>' % (x, height - 22, colours[p]))
        out.append('<text x="%d" y="%d">%s</text>' % (x + 18, height - 12, pane))
    out.append('<line x1="%d" y1="%d" x2="%d" y2="%d" stroke="black"/>' % (
        left, top + plot_h, width - 20, top + plot_h))
    out.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--refdir", default=os.environ.get("BST_REFDIR") or
                    os.path.join(os.path.dirname(TOP), "shared", "reference"))
    ap.add_argument("--out", default=os.path.join(TOP, "examples", "out", "python"))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    rows = study(args.refdir, lambda m: print(m, flush=True))
    write_csv(os.path.join(args.out, "param_study.csv"), rows)
    write_svg(os.path.join(args.out, "param_study.svg"), rows)
    print("wrote %s and %s" % (os.path.join(args.out, "param_study.csv"),
                               os.path.join(args.out, "param_study.svg")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
