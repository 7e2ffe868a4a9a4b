"""lrr from Python: relight a diffuse scene with any emission, in real time.

A ctypes binding of liblrr (include/lrr.h) with numpy arrays in and out; no compilation
step. The library is found by the environment variable LRR_LIBRARY (a path to liblrr.so),
else in the build tree this package sits in (../../.libs/liblrr.so), else in the libdir
`make install` recorded, else by ctypes.util.find_library('lrr').

    import lrr
    op = lrr.build("cornell", patches=216, levels=2)   # or lrr.load("box.lrr")
    B = op.solve()                        # the stored emission; (n, 3) float32
    E = op.emission * 2 + op.direct_light([lrr.lights.Point((278, 400, 280), (4e5,) * 3)])
    B = op.solve(E)
    op.export_gltf(B, "lit.glb", exposure="auto")

Arrays are (n, 3) float32, RGB per subpatch, in the operator's order (patch-major, what
lrr_solve takes) unless a call is given order="scene" (the order of `lrr solve --csv` rows
and lrr_scene_subpatch_at; the two differ only for a cluster hierarchy). Errors raise
lrr.LrrError carrying lrr's message and status code. See python/README.md.
"""
from . import lights
from ._core import (STATUS, Context, Lighting, LrrError, Operator, Scene, Solver, build,
                    build_operator, load)
from ._ffi import lib as _lib, library_path

globals().update(STATUS)  # lrr.ERR_DIM, lrr.ERR_IO, … (lrr_status codes)
__version__ = _lib.lrr_version_string().decode()

__all__ = ["Context", "LrrError", "Scene", "Operator", "Solver", "Lighting", "build",
           "build_operator", "load", "lights", "library_path", "STATUS"]
