#!/usr/bin/env python3
"""Relighting the Cornell box from Python, notebook style (one cell per step).

Builds the box's operator once (or loads one saved by `lrr preprocess`), then relights it
with a few emissions and a point light moving from the green wall to the red one: each
frame is one solve. Prints a table, writes the last frame as relit.glb and relit.png.

    PYTHONPATH=python LRR_LIBRARY=.libs/liblrr.so python3 examples/relight.py --out out
    python3 examples/relight.py --operator box.lrr      # after `lrr preprocess cornell -o box.lrr`
"""
import argparse
import os
import time

import numpy as np

import lrr

ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
ap.add_argument("--out", default=".", help="directory for relit.glb and relit.png")
ap.add_argument("--operator", help="an .lrr file; default: build the Cornell box")
ap.add_argument("--patches", type=int, default=216)
ap.add_argument("--levels", type=int, default=2)
ap.add_argument("--hemicube", type=int, default=128)
args = ap.parse_args()

# %% The operator: F̄ by hemicubes and the SMW matrices, the one slow step.
t = time.perf_counter()
if args.operator:
    op = lrr.load(args.operator)
else:
    op = lrr.build("cornell", patches=args.patches, levels=args.levels, hemicube=args.hemicube)
info = op.info
print("operator: n = %d subpatches, k = %d patches, %.2f s" % (info["n"], info["k"],
                                                               time.perf_counter() - t))

# %% Which subpatches are what: the walls by their normals (the box is in millimetres,
# the red wall at x = 556 faces -x, the green one at x = 0 faces +x). Arrays are in the
# operator's order, the order solve() takes and returns.
normal, area = op.normal, op.area
red, green = normal[:, 0] < -0.9, normal[:, 0] > 0.9
floor = normal[:, 1] > 0.9
ceiling_light = op.emission  # the scene's own emission: the light panel


def mean(b, where):
    """area-weighted mean radiosity over the subpatches `where`"""
    return (b[where] * area[where, None]).sum(0) / area[where].sum()


def row(name, b, ms):
    m = mean(b, np.ones(len(b), bool))
    print("%-18s %7.3f %7.3f %7.3f   %7.3f   %7.3f   %6.2f"
          % (name, m[0], m[1], m[2], mean(b, red)[0], mean(b, green)[1], ms))


print("%-18s %7s %7s %7s   %7s   %7s   %6s" % ("emission", "B_r", "B_g", "B_b", "red r",
                                                "green g", "ms"))

# %% Any emission: the light panel, then dimmed and blue, then a glowing floor.
floor_glow = np.zeros_like(ceiling_light)
floor_glow[floor] = (0.5, 0.5, 0.5)
for name, e in [("ceiling", ceiling_light),
                ("ceiling, bluer", ceiling_light * np.float32([0.2, 0.3, 1.0])),
                ("floor glow", floor_glow)]:
    t = time.perf_counter()
    b = op.solve(e)
    row(name, b, 1e3 * (time.perf_counter() - t))

# %% A point light moving across the box above the blocks (panel off): the direct light by
# shadow rays, then one solve adds the interreflections. Each frame re-traces only the light
# that moved.
for x in (100.0, 220.0, 340.0, 456.0):
    t = time.perf_counter()
    light = lrr.lights.Point(position=(x, 450.0, 280.0), rgb=(4e4, 4e4, 4e4))
    e = op.direct_light([light])
    b = op.solve(e)
    row("light x=%g" % x, b, 1e3 * (time.perf_counter() - t))

# %% The last frame for other programs: a glTF mesh and a picture.
os.makedirs(args.out, exist_ok=True)
exposure = op.auto_exposure(b)
op.export_gltf(b, os.path.join(args.out, "relit.glb"), exposure=exposure)
op.render_png(b, os.path.join(args.out, "relit.png"), width=320, height=320,
              exposure=exposure)
print("wrote %s and %s (exposure %.3g)" % (os.path.join(args.out, "relit.glb"),
                                          os.path.join(args.out, "relit.png"), exposure))
