"""Contexts, errors, scenes, operators, solvers, lighting and output (see lrr/__init__.py)."""
import ctypes
import os

import numpy as np

from . import _ffi
from ._ffi import lib

_STATUS_NAMES = ["OK", "NOT_CONVERGED", "ERR_INVALID_ARG", "ERR_NOMEM", "ERR_OVERFLOW",
                 "ERR_IO", "ERR_FORMAT", "ERR_CORRUPT", "ERR_VERSION", "ERR_GEOMETRY",
                 "ERR_MATERIAL", "ERR_EMPTY", "ERR_SINGULAR", "ERR_UNSUPPORTED",
                 "ERR_CANCELLED", "ERR_DIM", "ERR_BUDGET"]
# lrr_status codes as module constants: lrr.ERR_DIM == 15, …
STATUS = {name: code for code, name in enumerate(_STATUS_NAMES)}
ERR_INVALID_ARG = STATUS["ERR_INVALID_ARG"]
ERR_DIM = STATUS["ERR_DIM"]


class LrrError(Exception):
    """An lrr call failed. ``status`` is the lrr_status code (see include/lrr.h), ``name``
    its lrr_strerror text and ``message`` lrr's own message, naming what and where (the
    file, subpatch, channel or value); str(error) is the message."""

    def __init__(self, status, message):
        self.status = int(status)
        self.name = lib.lrr_strerror(self.status).decode()
        self.message = message or self.name
        super().__init__(self.message)


class Context:
    """An lrr_context: where the library records the message of an error. Every object keeps
    its context alive; one context may serve many objects. Not shared between threads that
    run calls at the same time (the error record is the context's)."""

    def __init__(self, on_error=None):
        """on_error(status, message), if given, sees every error lrr reports on this
        context (lrr_context_set_error_callback), in the thread that hit it; exceptions it
        raises are printed and dropped (ctypes cannot carry them through C)."""
        h = ctypes.c_void_p()
        status = lib.lrr_context_create(ctypes.byref(h))
        if status != 0:
            raise LrrError(status, "lrr_context_create failed")
        self._h = h
        self._on_error = None
        if on_error is not None:
            # kept on self: lrr holds only the C pointer, which dies with this object
            self._on_error = _ffi.ERROR_FN(
                lambda user, st, msg: on_error(st, msg.decode(errors="replace")))
            lib.lrr_context_set_error_callback(h, self._on_error, None)

    def __del__(self):
        if getattr(self, "_h", None):
            lib.lrr_context_destroy(self._h)
            self._h = None

    def last_error(self):
        """(status, message) of the first error since the last call, and clears it."""
        buf = ctypes.create_string_buffer(1024)
        status = lib.lrr_context_last_error(self._h, buf, len(buf))
        return status, buf.value.decode(errors="replace")

    def call(self, fn, *args):
        """Calls an lrr function that returns lrr_status; a failure raises LrrError with the
        message lrr recorded on this context. The record is cleared first, so the message is
        this call's and never an older one left unread."""
        self.last_error()
        status = fn(*args)
        if status != 0:
            recorded, message = self.last_error()
            raise LrrError(status, message if recorded != 0 else "")
        return status


def _context(context):
    return context if context is not None else Context()


def _path(path):
    return os.fsencode(path)


def _floats(what, array, shape):
    """array as a C-contiguous float32 numpy array of the given shape (None: any length in
    that place), or LrrError(ERR_DIM) naming what and both shapes. NaN and Inf pass: lrr
    checks values and names the entry."""
    a = np.ascontiguousarray(array, dtype=np.float32)
    if a.ndim != len(shape) or any(s is not None and s != t for s, t in zip(shape, a.shape)):
        want = "(" + ", ".join("any" if s is None else str(s) for s in shape) + ")"
        raise LrrError(ERR_DIM, "%s has shape %s, expected %s" % (what, a.shape, want))
    return a


def _fp(a):
    return a.ctypes.data_as(_ffi.c_float_p)


def _struct_dict(s):
    out = {}
    for name, _ in s._fields_:
        if name == "size":
            continue
        v = getattr(s, name)
        out[name] = tuple(v) if isinstance(v, ctypes.Array) else v
    return out


# ---------------------------------------------------------------- scenes
class Scene:
    """An lrr_scene: input triangles with reflectance and emission, subdivided into k patches
    of d subpatches. Create with Scene.load, Scene.builtin, Scene.open or Scene.from_arrays."""

    def __init__(self, handle, context):
        self._h, self.context = handle, context

    @property
    def h(self):
        """The C handle; LrrError after close()."""
        if not getattr(self, "_h", None):
            raise LrrError(ERR_INVALID_ARG, "%s: used after close()" % type(self).__name__)
        return self._h

    def close(self):
        """Destroys the scene now (also done when it is collected)."""
        if getattr(self, "_h", None):
            lib.lrr_scene_destroy(self._h)
            self._h = None

    __del__ = close

    @classmethod
    def load(cls, path, context=None):
        """An OBJ/PLY/glTF file (lrr_scene_load)."""
        ctx = _context(context)
        h = ctypes.c_void_p()
        ctx.call(lib.lrr_scene_load, ctx._h, _path(path), ctypes.byref(h))
        return cls(h, ctx)

    @classmethod
    def builtin(cls, name, context=None):
        """'cornell' or 'cornell-closed' (lrr_scene_builtin)."""
        ctx = _context(context)
        h = ctypes.c_void_p()
        ctx.call(lib.lrr_scene_builtin, ctx._h, name.encode(), ctypes.byref(h))
        return cls(h, ctx)

    @classmethod
    def open(cls, name, context=None):
        """A file, or a built-in name when no file of that name exists (as the lrr tool)."""
        if not os.path.exists(name) and name in ("cornell", "cornell-closed"):
            return cls.builtin(name, context)
        return cls.load(name, context)

    @classmethod
    def from_arrays(cls, vertices, rho, emission, source=None, context=None):
        """Triangles from arrays (lrr_scene_create): vertices (T, 9) or (T, 3, 3), corners
        counter-clockwise seen from the front; rho and emission (T, 3)."""
        v = np.ascontiguousarray(vertices, dtype=np.float32)
        t = v.shape[0] if v.ndim >= 1 else 0
        v = _floats("vertices", v.reshape(t, -1) if v.ndim == 3 else v, (t, 9))
        r = _floats("rho", rho, (t, 3))
        e = _floats("emission", emission, (t, 3))
        ctx = _context(context)
        h = ctypes.c_void_p()
        ctx.call(lib.lrr_scene_create, ctx._h, t, _fp(v), _fp(r), _fp(e),
                 source.encode() if source else None, ctypes.byref(h))
        return cls(h, ctx)

    def subdivide(self, patches=None, max_patch_area=None, levels=2):
        """lrr_scene_subdivide: split until about `patches` patches (or every patch has area
        <= max_patch_area; neither: one patch per triangle), then each patch `levels` times
        more (d = 4**levels)."""
        if patches is not None and max_patch_area is not None:
            raise LrrError(ERR_INVALID_ARG, "subdivide: patches and max_patch_area exclude "
                                            "each other")
        s = _ffi.Subdivision(size=ctypes.sizeof(_ffi.Subdivision),
                             max_patch_area=max_patch_area or 0.0,
                             target_patches=patches or 0, levels=levels)
        self.context.call(lib.lrr_scene_subdivide, self.h, ctypes.byref(s))
        return self

    @property
    def info(self):
        """lrr_scene_info as a dict (triangles, patches, subpatches, d, area, …)."""
        i = _ffi.SceneInfo()
        lib.lrr_scene_get_info(self.h, ctypes.byref(i), ctypes.sizeof(i))
        return _struct_dict(i)


# ---------------------------------------------------------------- operators
_FORMFACTOR = {"auto": 0, "raster": 1, "raycast": 2}
_SPLIT = {"variance": 0, "area": 1}
_BACKEND = {"cpu": _ffi.BACKEND_CPU, "opencl": _ffi.BACKEND_OPENCL}


_RECEIVER = {"auto": 0, "centre": 1, "center": 1, "area": 2}


def build_operator(scene, hemicube=128, seed=1, threads=0, no_rotation=False,
                   formfactor="auto", backend="cpu", memory_budget=0, adaptive=0,
                   clusters=0, adaptive_samples=2048, adaptive_split="variance",
                   storage="f32", progress=None, receiver="auto"):
    """lrr_operator_build on a subdivided Scene, then lrr_operator_set_storage. The options
    are lrr_build_options (include/lrr.h) under the names of `lrr preprocess`: adaptive=K an
    adaptive quadtree hierarchy, clusters=K a cluster hierarchy (both need levels=0 in the
    subdivision); progress(done, total) may return True to cancel (LrrError ERR_CANCELLED)."""
    if adaptive and clusters:
        raise LrrError(ERR_INVALID_ARG, "build: adaptive and clusters exclude each other")
    for name, value, table in (("formfactor", formfactor, _FORMFACTOR),
                               ("adaptive_split", adaptive_split, _SPLIT),
                               ("backend", backend, _BACKEND),
                               ("receiver", receiver, _RECEIVER)):
        if value not in table:
            raise LrrError(ERR_INVALID_ARG, "build: %s '%s' is not one of %s"
                           % (name, value, ", ".join(table)))
    cb = _ffi.PROGRESS_FN(lambda user, done, total: int(bool(progress(done, total)))) \
        if progress else _ffi.PROGRESS_FN()
    o = _ffi.BuildOptions(size=ctypes.sizeof(_ffi.BuildOptions),
                          hemicube_resolution=hemicube, seed=seed, threads=threads,
                          progress=cb, no_rotation=int(no_rotation),
                          backend=_BACKEND[backend],
                          memory_budget=memory_budget,
                          adaptive_patches=clusters or adaptive,
                          adaptive_samples=adaptive_samples,
                          adaptive_split=_SPLIT[adaptive_split],
                          formfactor_method=_FORMFACTOR[formfactor],
                          hierarchy=1 if clusters else 0,
                          receiver_sampling=_RECEIVER[receiver])
    h = ctypes.c_void_p()
    try:
        scene.context.call(lib.lrr_operator_build, scene.h, ctypes.byref(o), ctypes.byref(h))
    except LrrError:
        lib.lrr_operator_destroy(h)  # destroy(NULL) does nothing
        raise
    op = Operator(h, scene.context)
    if storage != "f32":
        op.set_storage(storage)
    return op


def build(scene="cornell", patches=None, max_patch_area=None, levels=None, context=None,
          **options):
    """Scene to operator in one call, with the defaults of `lrr preprocess` (tools/): scene a
    file or a built-in name (or a Scene); subdivision --patches 216 --levels 2 unless given
    (levels 0 with adaptive or clusters; with clusters and neither patches nor
    max_patch_area, about triangles + 16·K subpatches); **options go to build_operator."""
    sc = scene if isinstance(scene, Scene) else Scene.open(scene, context)
    hierarchy = options.get("adaptive") or options.get("clusters")
    if levels is None:
        levels = 0 if hierarchy else 2
    if patches is None and max_patch_area is None:
        if options.get("clusters"):
            patches = sc.info["triangles"] + 16 * options["clusters"]
        else:
            patches = 216
    sc.subdivide(patches=patches, max_patch_area=max_patch_area, levels=levels)
    return build_operator(sc, **options)


def load(path, context=None):
    """An operator saved by `lrr preprocess` or Operator.save (lrr_operator_load)."""
    ctx = _context(context)
    h = ctypes.c_void_p()
    ctx.call(lib.lrr_operator_load, ctx._h, _path(path), ctypes.byref(h))
    return Operator(h, ctx)


class Operator:
    """An lrr_operator (F̄ and M_c) of n subpatches in k patches.

    Subpatch order: every per-subpatch array (emission, radiosity, area, centre, …) is in the
    *operator's* order unless a method is given order="scene". The operator's order is
    patch-major (patch p holds subpatches patch_offsets[p] .. patch_offsets[p+1]-1): what
    lrr_solve, lrr_lighting_direct and the exporters take. The scene's order is that of
    lrr_scene_subpatch_at and of `lrr solve --csv` rows. They differ only for a cluster
    hierarchy (clusters=K), where scene_index[i] is the scene's index of subpatch i."""

    def __init__(self, handle, context):
        self._h, self.context = handle, context
        self._solver = None
        self._lighting = None
        self._nk = None

    @property
    def h(self):
        """The C handle; LrrError after close()."""
        if not getattr(self, "_h", None):
            raise LrrError(ERR_INVALID_ARG, "%s: used after close()" % type(self).__name__)
        return self._h

    def close(self):
        """Destroys the operator now (also done when it is collected). Its own solver and
        lighting go first, explicitly: they point back to it, and the collector finalises
        such a cycle in no fixed order, while lrr needs the operator to outlive them."""
        for helper in (getattr(self, "_solver", None), getattr(self, "_lighting", None)):
            if helper is not None:
                helper.close()
        self._solver = self._lighting = None
        if getattr(self, "_h", None):
            lib.lrr_operator_destroy(self._h)
            self._h = None

    __del__ = close

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # ------------------------------------------------------------ description
    @property
    def info(self):
        """lrr_operator_info as a dict (n, k, d, triangles, condition, storage, …)."""
        i = _ffi.OperatorInfo()
        lib.lrr_operator_get_info(self.h, ctypes.byref(i), ctypes.sizeof(i))
        d = _struct_dict(i)
        d["storage"] = lib.lrr_storage_name(i.storage).decode()
        d["layout"] = "rows" if i.layout == 1 else "panels"
        d["hierarchy"] = "clusters" if i.hierarchy == 1 else "quadtree"
        d["receiver_sampling"] = "area" if i.receiver_sampling == 2 else "centre"
        return d

    def verify(self, scene, samples=0, seed=0, threads=0, progress=None):
        """lrr_operator_verify: the operator's error bar against the path tracer on the scene
        it was built from (subdivided as for the build). Returns (and keeps, for info and save)
        {'rel_l2', 'noise', 'subpatches', 'samples', 'seconds', 'uniform'}."""
        if not isinstance(scene, Scene):
            raise LrrError(ERR_INVALID_ARG, "verify: scene must be a Scene")
        self._drop_solver()  # no solver may run meanwhile
        cb = _ffi.PROGRESS_FN(lambda user, done, total: int(bool(progress(done, total)))) \
            if progress else _ffi.PROGRESS_FN()
        o = _ffi.VerifyOptions(size=ctypes.sizeof(_ffi.VerifyOptions), samples=samples,
                               seed=seed, threads=threads, progress=cb)
        self.context.call(lib.lrr_operator_verify, self.h, scene.h, ctypes.byref(o))
        i = self.info
        return {k: i["verify_" + k] for k in ("rel_l2", "noise", "subpatches", "samples",
                                              "seconds", "uniform")}

    def _sizes(self):
        # n and k are fixed for the operator's life: read once, since every frame needs n
        if self._nk is None:
            i = self.info
            self._nk = (i["n"], i["k"])
        return self._nk

    @property
    def n(self):
        """Subpatches."""
        return self._sizes()[0]

    @property
    def k(self):
        """Patches."""
        return self._sizes()[1]

    def _rows(self, fn, width=3):
        p = fn(self.h)
        n = self.n
        if not p:
            return None
        return np.ctypeslib.as_array(p, shape=(n, width) if width > 1 else (n,)).copy()

    @property
    def emission(self):
        """The stored scene emission (n, 3), operator order (a copy)."""
        return self._rows(lib.lrr_operator_emission)

    @property
    def reflectance(self):
        return self._rows(lib.lrr_operator_reflectance)

    @property
    def area(self):
        return self._rows(lib.lrr_operator_area, 1)

    @property
    def centre(self):
        return self._rows(lib.lrr_operator_centre)

    @property
    def normal(self):
        return self._rows(lib.lrr_operator_normal)

    @property
    def patch_offsets(self):
        """k + 1 offsets into the operator's order (patch p is offsets[p]:offsets[p+1])."""
        p = lib.lrr_operator_patch_offsets(self.h)
        return np.ctypeslib.as_array(p, shape=(self.k + 1,)).astype(np.int64)

    @property
    def scene_index(self):
        """n entries: the scene-order index of each subpatch (identity but for clusters)."""
        p = lib.lrr_operator_subpatch_origin(self.h)
        n = self.n
        if not p:
            return np.arange(n, dtype=np.int64)
        return np.ctypeslib.as_array(p, shape=(n,)).astype(np.int64)

    def fbar(self):
        """F̄ (n, k), decoded from any storage (row by row through lrr_operator_fbar_row)."""
        n, k = self.n, self.k
        out = np.empty((n, k), dtype=np.float32)
        for i in range(n):
            lib.lrr_operator_fbar_row(self.h, i, _fp(out[i]))
        return out

    def subpatch_vertices(self):
        """The corners of every subpatch (n, 3, 3), operator order."""
        out = np.empty((self.n, 3, 3), dtype=np.float32)
        lib.lrr_operator_subpatch_vertices(self.h, _fp(out))
        return out

    # ------------------------------------------------------------ orders
    def to_scene_order(self, x):
        """Per-subpatch rows (n, …) from the operator's order into the scene's."""
        x = np.asarray(x)
        out = np.empty_like(x)
        out[self.scene_index] = x
        return out

    def from_scene_order(self, x):
        """Per-subpatch rows (n, …) from the scene's order into the operator's."""
        return np.asarray(x)[self.scene_index]

    def _in(self, what, x, order):
        if order not in ("operator", "scene"):
            raise LrrError(ERR_INVALID_ARG, "%s: order '%s' is not 'operator' or 'scene'"
                           % (what, order))
        a = _floats(what, x, (self.n, 3))
        return np.ascontiguousarray(self.from_scene_order(a)) if order == "scene" else a

    # ------------------------------------------------------------ changes
    def set_reflectance(self, rho, order="operator"):
        """New reflectances (n, 3), each in [0, 1): M_c recomputed from the stored F̄."""
        r = self._in("reflectance", rho, order)
        self._drop_solver()  # no solver may run meanwhile; its caches would be stale
        self.context.call(lib.lrr_operator_set_reflectance, self.h, _fp(r))

    def set_storage(self, storage):
        """'f32', 'f16' or 'bf16' (lrr_operator_set_storage)."""
        s = ctypes.c_int()
        self.context.call(lib.lrr_storage_from_name, str(storage).encode(), ctypes.byref(s))
        self._drop_solver()  # lrr: destroy the operator's solvers first
        self.context.call(lib.lrr_operator_set_storage, self.h, s.value)

    def set_layout(self, layout):
        """'panels' (what build and load give; the fast one) or 'rows' (lrr_operator_set_layout):
        where F̄'s entries sit in memory, never their values."""
        names = {"panels": 0, "rows": 1}
        if layout not in names:
            raise ValueError("layout must be 'panels' or 'rows', not %r" % (layout,))
        self._drop_solver()  # lrr: destroy the operator's solvers first
        self.context.call(lib.lrr_operator_set_layout, self.h, names[layout])

    def _drop_solver(self):
        if self._solver is not None:
            self._solver.close()
            self._solver = None

    def save(self, path, fbar="auto"):
        """lrr_operator_save_fbar (atomic): F̄ stored "dense", "sparse" (its 16-row strips that
        hold a nonzero, file version 5) or "auto" (sparse where that is at most half the
        bytes, as lrr_operator_save)."""
        if fbar not in Solver.FBAR:
            raise LrrError(ERR_INVALID_ARG, "save: fbar '%s' is not one of %s"
                           % (fbar, ", ".join(Solver.FBAR)))
        self.context.call(lib.lrr_operator_save_fbar, self.h, _path(path),
                          Solver.FBAR.index(fbar))

    # ------------------------------------------------------------ solving
    def solver(self, backend="cpu", fbar="auto", m="auto"):
        """A new Solver ('cpu' or 'opencl'; fbar 'auto', 'dense' or 'sparse': Solver.set_fbar;
        m 'auto', 'f32' or 'f16': Solver.set_m)."""
        return Solver(self, backend, fbar, m)

    def solve(self, emission=None, order="operator"):
        """B (n, 3) float32 for emission E (n, 3), finite and >= 0; None: the stored
        emission. order: "operator" (default) or "scene", for both E and B. Uses one CPU
        solver kept by the operator."""
        if self._solver is None:
            self._solver = Solver(self, "cpu")
        return self._solver.solve(emission, order)

    def solve_batch(self, emissions, order="operator"):
        """B (m, n, 3) for m emissions (m, n, 3) at once (lrr_solve_batch)."""
        if self._solver is None:
            self._solver = Solver(self, "cpu")
        return self._solver.solve_batch(emissions, order)

    def direct_light(self, lights, order="operator"):
        """The reflected direct light of lights (see lrr.lights) as an emission (n, 3):
        E = rho ∘ H, to add to the scene's emission and solve. Keeps one Lighting (its BVH)."""
        if self._lighting is None:
            self._lighting = Lighting(self)
        return self._lighting.direct(lights, order)

    # ------------------------------------------------------------ output
    def _radiosity(self, radiosity, order):
        return self._in("radiosity", radiosity, order)

    def _export_options(self, exposure, subpatches):
        return _ffi.ExportOptions(size=ctypes.sizeof(_ffi.ExportOptions),
                                  subpatches=int(subpatches),
                                  exposure=0.0 if exposure == "auto" else float(exposure))

    def export_gltf(self, radiosity, path, exposure=1.0, subpatches=False, order="operator"):
        """The lit mesh as binary glTF (lrr_export_gltf): COLOR_0 = min(1, B × exposure),
        _RADIOSITY = B; exposure "auto" as lrr_render_png's."""
        b = self._radiosity(radiosity, order)
        o = self._export_options(exposure, subpatches)
        self.context.call(lib.lrr_export_gltf, self.h, _fp(b), ctypes.byref(o), _path(path))

    def export_ply(self, radiosity, path, exposure=1.0, subpatches=False, order="operator"):
        """The same mesh as binary PLY (lrr_export_ply)."""
        b = self._radiosity(radiosity, order)
        o = self._export_options(exposure, subpatches)
        self.context.call(lib.lrr_export_ply, self.h, _fp(b), ctypes.byref(o), _path(path))

    def export_info(self, radiosity, exposure=1.0, subpatches=False, order="operator"):
        """What export_gltf would write: dict of vertices, triangles, materials, exposure."""
        b = self._radiosity(radiosity, order)
        o = self._export_options(exposure, subpatches)
        i = _ffi.ExportInfo()
        self.context.call(lib.lrr_export_get_info, self.h, _fp(b), ctypes.byref(o),
                          b"(export_info)", ctypes.byref(i), ctypes.sizeof(i))
        return _struct_dict(i)

    def auto_exposure(self, radiosity, order="operator"):
        """lrr_render_auto_exposure: fix it across frames so that a sequence does not
        flicker."""
        b = self._radiosity(radiosity, order)
        return lib.lrr_render_auto_exposure(self.h, _fp(b))

    def render_png(self, radiosity, path, width=512, height=512, exposure=0.0, eye=None,
                   target=None, up=(0, 1, 0), fov_degrees=0.0, cornell_camera=-1,
                   order="operator"):
        """A picture (lrr_render_png): exposure 0 automatic; eye and target a pinhole camera,
        else cornell_camera 1 (the Cornell camera), 0 (framing) or -1 (automatic)."""
        b = self._radiosity(radiosity, order)
        o = _ffi.RenderOptions(size=ctypes.sizeof(_ffi.RenderOptions), width=width,
                               height=height, exposure=exposure,
                               use_cornell_camera=cornell_camera, up=tuple(up),
                               fov_degrees=fov_degrees, use_eye=int(eye is not None))
        if eye is not None:
            o.eye = tuple(eye)
            o.target = tuple(target if target is not None else (0, 0, 0))
        self.context.call(lib.lrr_render_png, self.h, _fp(b), ctypes.byref(o), _path(path))


class Solver:
    """An lrr_solver: one backend's buffers for an operator (which it keeps alive)."""

    def __init__(self, op, backend="cpu", fbar="auto", m="auto"):
        if backend not in _BACKEND:
            raise LrrError(ERR_INVALID_ARG, "solver: backend '%s' is not cpu or opencl"
                           % backend)
        self.op = op
        h = ctypes.c_void_p()
        op.context.call(lib.lrr_solver_create, op.h, _BACKEND[backend], ctypes.byref(h))
        self._h = h
        if fbar != "auto":
            self.set_fbar(fbar)
        if m != "auto":
            self.set_m(m)

    FBAR = ("auto", "dense", "sparse")
    M = ("f32", "f16")

    def set_m(self, name):
        """How a full frame reads M: "f32", or "f16" (M − I in binary16 with a scale per row,
        half the bytes; the default when F̄ is 16-bit; lrr_solver_set_m)."""
        if name not in self.M:
            raise LrrError(ERR_INVALID_ARG, "solver: m '%s' is not one of %s"
                           % (name, ", ".join(self.M)))
        self.op.context.call(lib.lrr_solver_set_m, self.h, self.M.index(name))

    def set_fbar(self, name):
        """How F̄ is read: "dense", "sparse" (only the 16-row strips that hold a nonzero) or
        "auto" (sparse where that reads at most half the bytes; lrr_solver_set_fbar)."""
        if name not in self.FBAR:
            raise LrrError(ERR_INVALID_ARG, "solver: fbar '%s' is not one of %s"
                           % (name, ", ".join(self.FBAR)))
        self.op.context.call(lib.lrr_solver_set_fbar, self.h, self.FBAR.index(name))

    @property
    def info(self):
        """lrr_solver_info as a dict: fbar ("dense" or "sparse"), fbar_bytes (read per full
        frame), fbar_dense_bytes, m ("f32" or "f16") and m_bytes (read per full frame),
        fbar_density, fbar_strip_density."""
        i = _ffi.SolverInfo()
        lib.lrr_solver_get_info(self.h, ctypes.byref(i), ctypes.sizeof(i))
        d = _struct_dict(i)
        d["fbar"] = self.FBAR[i.fbar]
        d["m"] = self.M[i.m]
        return d

    @property
    def h(self):
        """The C handle; LrrError after close()."""
        if not getattr(self, "_h", None):
            raise LrrError(ERR_INVALID_ARG, "%s: used after close()" % type(self).__name__)
        return self._h

    def close(self):
        if getattr(self, "_h", None):
            lib.lrr_solver_destroy(self._h)
            self._h = None

    __del__ = close

    PATHS = ("auto", "full", "sparse", "incremental")

    @property
    def last_path(self):
        """The path the last frame took: "full", "sparse" or "incremental"."""
        return self.PATHS[lib.lrr_solver_last_path(self.h)]

    def set_path(self, name):
        """Forces a path ("full", "sparse", "incremental") or "auto", the default: each
        frame takes the cheapest (lrr_solver_set_path)."""
        if name not in self.PATHS:
            raise LrrError(ERR_INVALID_ARG, "solver: path '%s' is not one of %s"
                           % (name, ", ".join(self.PATHS)))
        self.op.context.call(lib.lrr_solver_set_path, self.h, self.PATHS.index(name))

    @property
    def kernel(self):
        """"c", "avx2", "avx512" (+"+prefetch" on Intel) or "opencl:<device>" (lrr_solver_kernel)."""
        return lib.lrr_solver_kernel(self.h).decode()

    def solve(self, emission=None, order="operator"):
        """See Operator.solve."""
        op = self.op
        e = op.emission if emission is None else op._in("emission", emission, order)
        b = np.empty_like(e)
        op.context.call(lib.lrr_solve, self.h, _fp(e), _fp(b))
        return op.to_scene_order(b) if order == "scene" else b

    def solve_batch(self, emissions, order="operator"):
        """See Operator.solve_batch."""
        op = self.op
        if order not in ("operator", "scene"):
            raise LrrError(ERR_INVALID_ARG, "solve_batch: order '%s' is not 'operator' or "
                                            "'scene'" % order)
        e = _floats("emissions", emissions, (None, op.n, 3))
        if order == "scene":
            e = np.ascontiguousarray(e[:, op.scene_index])
        b = np.empty_like(e)
        if len(e):
            op.context.call(lib.lrr_solve_batch, self.h, len(e), _fp(e), _fp(b))
        if order == "scene":
            out = np.empty_like(b)
            out[:, op.scene_index] = b
            return out
        return b


class Lighting:
    """An lrr_lighting: the BVH of an operator's triangles, for lrr_lighting_direct."""

    def __init__(self, op, tolerance=0.0):
        """tolerance: the shadow rays' error budget (set_tolerance)."""
        self.op = op
        h = ctypes.c_void_p()
        op.context.call(lib.lrr_lighting_create, op.h, ctypes.byref(h))
        self._h = h
        if tolerance:
            self.set_tolerance(tolerance)

    def set_tolerance(self, tolerance):
        """lrr_lighting_set_tolerance: point and spot lights trace only the receivers that
        carry most of their light, each light's area-weighted L2 error in rho ∘ H within
        tolerance (0: every ray)."""
        self.op.context.call(lib.lrr_lighting_set_tolerance, self.h, float(tolerance))

    @property
    def h(self):
        """The C handle; LrrError after close()."""
        if not getattr(self, "_h", None):
            raise LrrError(ERR_INVALID_ARG, "%s: used after close()" % type(self).__name__)
        return self._h

    def close(self):
        if getattr(self, "_h", None):
            lib.lrr_lighting_destroy(self._h)
            self._h = None

    __del__ = close

    def direct(self, lights, order="operator"):
        """E = rho ∘ H (n, 3) of a sequence of lights (lrr.lights classes or dicts)."""
        from .lights import to_c
        arr = to_c(lights)
        out = np.zeros((self.op.n, 3), dtype=np.float32)
        self.op.context.call(lib.lrr_lighting_direct, self.h, arr, len(arr), _fp(out))
        return self.op.to_scene_order(out) if order == "scene" else out

    @property
    def rays(self):
        """Shadow rays the last direct() cast (unchanged lights cast none)."""
        return lib.lrr_lighting_rays(self.h)
