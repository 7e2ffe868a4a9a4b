"""The C side of the binding: finding liblrr, the struct mirrors and the prototypes.

Every struct below mirrors one of include/lrr.h field for field, in the same order with the
same C types, so that ctypes lays it out as the C compiler does; python/tests/test_lrr.py
compiles a small C program against lrr.h and checks every sizeof and offsetof against these
mirrors. Option structs start with ``size``, which the binding sets to ctypes.sizeof of the
mirror (the C convention of lrr_*_defaults(): lrr reads the fields that size covers).
"""
import ctypes
import ctypes.util
import os

c_size_t = ctypes.c_size_t
c_float_p = ctypes.POINTER(ctypes.c_float)
c_size_t_p = ctypes.POINTER(ctypes.c_size_t)

# lrr_progress_fn: int (*)(void *user, size_t done, size_t total)
PROGRESS_FN = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, c_size_t, c_size_t)

# lrr_error_fn: void (*)(void *user, lrr_status status, const char *message)
ERROR_FN = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_int, ctypes.c_char_p)

BACKEND_CPU = 301
BACKEND_OPENCL = 302
BACK_FACE_WORST = 5


def _f3():
    return ctypes.c_float * 3


def _d3():
    return ctypes.c_double * 3


class Subdivision(ctypes.Structure):
    _fields_ = [("size", c_size_t),
                ("max_patch_area", ctypes.c_double),
                ("target_patches", c_size_t),
                ("levels", ctypes.c_uint)]


class SceneInfo(ctypes.Structure):
    _fields_ = [("triangles", c_size_t), ("skipped", c_size_t), ("patches", c_size_t),
                ("subpatches", c_size_t), ("d", c_size_t), ("emitters", c_size_t),
                ("area", ctypes.c_double), ("max_patch_area", ctypes.c_double),
                ("bounds_min", _d3()), ("bounds_max", _d3()),
                ("textures", c_size_t), ("clamped_texels", c_size_t)]


class BuildOptions(ctypes.Structure):
    _fields_ = [("size", c_size_t),
                ("hemicube_resolution", ctypes.c_uint),
                ("seed", ctypes.c_uint64),
                ("threads", ctypes.c_int),
                ("progress", PROGRESS_FN),
                ("progress_user", ctypes.c_void_p),
                ("no_rotation", ctypes.c_int),
                ("backend", ctypes.c_int),
                ("memory_budget", c_size_t),
                ("adaptive_patches", c_size_t),
                ("adaptive_samples", c_size_t),
                ("adaptive_split", ctypes.c_int),
                ("formfactor_method", ctypes.c_int),
                ("hierarchy", ctypes.c_int),
                ("receiver_sampling", ctypes.c_int)]


class OperatorInfo(ctypes.Structure):
    _fields_ = [("n", c_size_t), ("k", c_size_t), ("d", c_size_t), ("triangles", c_size_t),
                ("d_min", c_size_t), ("d_max", c_size_t),
                ("selection_seconds", ctypes.c_double),
                ("storage", ctypes.c_int),  # lrr_storage, a C enum: int
                ("condition", _d3()),
                ("build_seconds", ctypes.c_double),
                ("hemicube_resolution", ctypes.c_uint),
                ("seed", ctypes.c_uint64),
                ("no_rotation", ctypes.c_int),
                ("bytes", c_size_t),
                ("formfactor_method", ctypes.c_int),
                ("back_face_share", ctypes.c_double),
                ("worst_back_face_triangle", c_size_t * BACK_FACE_WORST),
                ("worst_back_face_share", ctypes.c_double * BACK_FACE_WORST),
                ("hierarchy", ctypes.c_int),
                ("formfactor_seconds", ctypes.c_double),
                ("smw_seconds", ctypes.c_double),
                ("layout", ctypes.c_int),
                ("receiver_sampling", ctypes.c_int),
                ("verify_rel_l2", ctypes.c_double),
                ("verify_noise", ctypes.c_double),
                ("verify_subpatches", c_size_t),
                ("verify_samples", c_size_t),
                ("verify_seconds", ctypes.c_double),
                ("verify_uniform", ctypes.c_int)]


class VerifyOptions(ctypes.Structure):
    _fields_ = [("size", c_size_t),
                ("samples", c_size_t),
                ("seed", ctypes.c_uint64),
                ("threads", ctypes.c_int),
                ("progress", PROGRESS_FN),
                ("progress_user", ctypes.c_void_p)]


class SolverInfo(ctypes.Structure):
    _fields_ = [("fbar", ctypes.c_int),
                ("fbar_bytes", c_size_t),
                ("fbar_dense_bytes", c_size_t),
                ("m_bytes", c_size_t),
                ("fbar_density", ctypes.c_double),
                ("fbar_strip_density", ctypes.c_double),
                ("m", ctypes.c_int)]


class LightSource(ctypes.Structure):
    _fields_ = [("kind", ctypes.c_int),
                ("position", _f3()), ("direction", _f3()),
                ("u", _f3()), ("v", _f3()), ("rgb", _f3()),
                ("cone_angle", ctypes.c_float),
                ("cone_softness", ctypes.c_float),
                ("samples", ctypes.c_uint)]


class ExportOptions(ctypes.Structure):
    _fields_ = [("size", c_size_t),
                ("subpatches", ctypes.c_int),
                ("exposure", ctypes.c_double)]


class ExportInfo(ctypes.Structure):
    _fields_ = [("vertices", c_size_t), ("triangles", c_size_t), ("materials", c_size_t),
                ("exposure", ctypes.c_double)]


class RenderOptions(ctypes.Structure):
    _fields_ = [("size", c_size_t),
                ("width", ctypes.c_uint), ("height", ctypes.c_uint),
                ("exposure", ctypes.c_double),
                ("use_cornell_camera", ctypes.c_int),
                ("eye", _d3()), ("target", _d3()), ("up", _d3()),
                ("fov_degrees", ctypes.c_double),
                ("use_eye", ctypes.c_int)]


# The mirrors by their C names, for the layout test.
STRUCTS = {"lrr_subdivision": Subdivision, "lrr_scene_info": SceneInfo,
           "lrr_build_options": BuildOptions, "lrr_operator_info": OperatorInfo,
           "lrr_light_source": LightSource, "lrr_export_options": ExportOptions,
           "lrr_export_info": ExportInfo, "lrr_render_options": RenderOptions,
           "lrr_verify_options": VerifyOptions, "lrr_solver_info": SolverInfo}

_P = ctypes.c_void_p  # every opaque handle
_S = ctypes.c_int     # lrr_status
_STR = ctypes.c_char_p

# name: (restype, argtypes)
_PROTOTYPES = {
    "lrr_strerror": (_STR, [_S]),
    "lrr_version_string": (_STR, []),
    "lrr_context_create": (_S, [ctypes.POINTER(_P)]),
    "lrr_context_destroy": (None, [_P]),
    "lrr_context_last_error": (_S, [_P, ctypes.c_char_p, c_size_t]),
    "lrr_context_set_error_callback": (None, [_P, ERROR_FN, ctypes.c_void_p]),
    "lrr_scene_load": (_S, [_P, _STR, ctypes.POINTER(_P)]),
    "lrr_scene_builtin": (_S, [_P, _STR, ctypes.POINTER(_P)]),
    "lrr_scene_create": (_S, [_P, c_size_t, c_float_p, c_float_p, c_float_p, _STR,
                              ctypes.POINTER(_P)]),
    "lrr_scene_destroy": (None, [_P]),
    "lrr_scene_subdivide": (_S, [_P, ctypes.POINTER(Subdivision)]),
    "lrr_scene_get_info": (None, [_P, ctypes.POINTER(SceneInfo), c_size_t]),
    "lrr_operator_build": (_S, [_P, ctypes.POINTER(BuildOptions), ctypes.POINTER(_P)]),
    "lrr_operator_destroy": (None, [_P]),
    "lrr_operator_save": (_S, [_P, _STR]),
    "lrr_operator_save_fbar": (_S, [_P, _STR, ctypes.c_int]),
    "lrr_operator_load": (_S, [_P, _STR, ctypes.POINTER(_P)]),
    "lrr_operator_set_reflectance": (_S, [_P, c_float_p]),
    "lrr_operator_set_storage": (_S, [_P, ctypes.c_int]),
    "lrr_operator_set_layout": (_S, [_P, ctypes.c_int]),
    "lrr_storage_from_name": (_S, [_STR, ctypes.POINTER(ctypes.c_int)]),
    "lrr_storage_name": (_STR, [ctypes.c_int]),
    "lrr_operator_get_info": (None, [_P, ctypes.POINTER(OperatorInfo), c_size_t]),
    "lrr_operator_fbar_row": (None, [_P, c_size_t, c_float_p]),
    "lrr_operator_reflectance": (c_float_p, [_P]),
    "lrr_operator_emission": (c_float_p, [_P]),
    "lrr_operator_area": (c_float_p, [_P]),
    "lrr_operator_centre": (c_float_p, [_P]),
    "lrr_operator_normal": (c_float_p, [_P]),
    "lrr_operator_patch_offsets": (c_size_t_p, [_P]),
    "lrr_operator_subpatch_origin": (c_size_t_p, [_P]),
    "lrr_operator_subpatch_vertices": (None, [_P, c_float_p]),
    "lrr_operator_verify": (_S, [_P, _P, ctypes.POINTER(VerifyOptions)]),
    "lrr_solver_create": (_S, [_P, ctypes.c_int, ctypes.POINTER(_P)]),
    "lrr_solver_destroy": (None, [_P]),
    "lrr_solver_kernel": (_STR, [_P]),
    "lrr_solver_set_fbar": (_S, [_P, ctypes.c_int]),
    "lrr_solver_set_m": (_S, [_P, ctypes.c_int]),
    "lrr_solver_get_info": (None, [_P, ctypes.POINTER(SolverInfo), c_size_t]),
    "lrr_solve": (_S, [_P, c_float_p, c_float_p]),
    "lrr_solver_set_path": (_S, [_P, ctypes.c_int]),
    "lrr_solver_last_path": (ctypes.c_int, [_P]),
    "lrr_solve_batch": (_S, [_P, c_size_t, c_float_p, c_float_p]),
    "lrr_lighting_create": (_S, [_P, ctypes.POINTER(_P)]),
    "lrr_lighting_destroy": (None, [_P]),
    "lrr_lighting_direct": (_S, [_P, ctypes.POINTER(LightSource), c_size_t, c_float_p]),
    "lrr_lighting_rays": (ctypes.c_uint64, [_P]),
    "lrr_lighting_set_tolerance": (_S, [_P, ctypes.c_double]),
    "lrr_render_png": (_S, [_P, c_float_p, ctypes.POINTER(RenderOptions), _STR]),
    "lrr_render_auto_exposure": (ctypes.c_double, [_P, c_float_p]),
    "lrr_export_gltf": (_S, [_P, c_float_p, ctypes.POINTER(ExportOptions), _STR]),
    "lrr_export_ply": (_S, [_P, c_float_p, ctypes.POINTER(ExportOptions), _STR]),
    "lrr_export_get_info": (_S, [_P, c_float_p, ctypes.POINTER(ExportOptions), _STR,
                                 ctypes.POINTER(ExportInfo), c_size_t]),
}


def _candidates():
    """Where liblrr is looked for, in order (see python/README.md)."""
    env = os.environ.get("LRR_LIBRARY")
    if env:
        return [env]  # an explicit choice: no fallback that would hide a wrong path
    here = os.path.dirname(os.path.abspath(__file__))
    # an in-tree build: python/lrr/../../.libs
    out = [os.path.normpath(os.path.join(here, "..", "..", ".libs", "liblrr.so"))]
    try:
        from . import _libdir  # written by `make install`: the configured libdir
        out.append(os.path.join(_libdir.LIBDIR, "liblrr.so.1"))
    except ImportError:
        pass
    found = ctypes.util.find_library("lrr")
    if found:
        out.append(found)
    return out


def load_library():
    """The first liblrr of _candidates() that exists, with its prototypes declared."""
    tried = []
    for path in _candidates():
        if os.sep in path and not os.path.exists(path):
            tried.append(path)
            continue
        lib = ctypes.CDLL(path)
        for name, (res, args) in _PROTOTYPES.items():
            fn = getattr(lib, name)
            fn.restype = res
            fn.argtypes = args
        return lib, path
    raise OSError("lrr: liblrr not found (tried %s and ctypes.util.find_library('lrr')); "
                  "set LRR_LIBRARY to the path of liblrr.so" % ", ".join(tried or ["nothing"]))


lib, library_path = load_library()
