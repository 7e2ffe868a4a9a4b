"""Tests of the Python binding (python/lrr) against the built library, run by tests/python.sh.

Environment (set by make check): LRR_LIBRARY (liblrr.so), LRR_BIN (the lrr tool),
LRR_SRCDIR (the source tree), LRR_BUILDDIR (the build tree, for lrr_version.h),
LRR_TEST_TMP (a writable directory), CC (a C compiler, for the struct layouts).
"""
import csv
import ctypes
import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import unittest

import numpy as np

import lrr

SRCDIR = os.environ.get("LRR_SRCDIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BUILDDIR = os.environ.get("LRR_BUILDDIR", SRCDIR)
LRR_BIN = os.environ.get("LRR_BIN", os.path.join(BUILDDIR, "lrr"))


def built_with(feature):
    """Whether this liblrr has an optional feature (lrr_features(): assimp, openexr, ...)."""
    f = ctypes.CDLL(os.environ.get("LRR_LIBRARY", "liblrr.so.1")).lrr_features
    f.restype = ctypes.c_char_p
    return feature in f().decode().split()


def tmpdir():
    return tempfile.mkdtemp(prefix="python.", dir=os.environ.get("LRR_TEST_TMP"))


def max_rel(a, b):
    """max |a − b| relative to max |b|"""
    return float(np.max(np.abs(np.asarray(a, np.float64) - b)) / np.max(np.abs(b)))


def run_lrr(*args):
    r = subprocess.run([LRR_BIN] + [str(a) for a in args], capture_output=True, text=True)
    if r.returncode != 0:
        raise AssertionError("lrr %s: exit %d\n%s" % (" ".join(args), r.returncode, r.stderr))
    return dict(line.split(": ", 1) for line in r.stdout.splitlines() if ": " in line)


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    col = lambda *names: np.array([[float(r[n]) for n in names] for r in rows])
    return col("cx", "cy", "cz"), col("b_r", "b_g", "b_b")


def box_inward(sx, sy, sz):
    """tests/testutil.h tu_box_inward: 12 triangles, every face counter-clockwise seen from
    inside, faces x=0, x=sx, y=0, y=sy, z=0, z=sz."""
    c = [((i & 1) * sx, ((i >> 1) & 1) * sy, ((i >> 2) & 1) * sz) for i in range(8)]
    faces = [(0, 2, 6, 4), (1, 5, 7, 3), (0, 4, 5, 1), (2, 3, 7, 6), (0, 1, 3, 2), (4, 6, 7, 5)]
    tris = []
    for a, b, cc, d in faces:
        tris += [c[a] + c[b] + c[cc], c[a] + c[cc] + c[d]]
    return np.array(tris, dtype=np.float32)


def quad_up(size):
    """One square [−size/2, size/2]² in the plane y = 0, facing +y (two triangles)."""
    h = size / 2
    p = [(-h, 0, -h), (-h, 0, h), (h, 0, h), (h, 0, -h)]  # counter-clockwise seen from +y
    return np.array([p[0] + p[1] + p[2], p[0] + p[2] + p[3]], dtype=np.float32)


def layout_program():
    """A C program printing, for every struct mirror and every one of its fields, the C
    compiler's sizeof and offsetof: "T sizeof N", "T.F offset N", "T.F size N"."""
    lines = ["#include <stddef.h>", "#include <stdio.h>", '#include "lrr.h"',
             "int main(void)", "{"]
    for name, mirror in lrr._ffi.STRUCTS.items():
        lines.append('    printf("%s sizeof %%zu\\n", sizeof(%s));' % (name, name))
        for field, _ in mirror._fields_:
            lines.append('    printf("%s.%s offset %%zu\\n", offsetof(%s, %s));'
                         % (name, field, name, field))
            lines.append('    printf("%s.%s size %%zu\\n", sizeof(((%s *)0)->%s));'
                         % (name, field, name, field))
    return "\n".join(lines + ["    return 0;", "}", ""])


def dense_model(op, e, rho=None):
    """numpy's dense solve of the low-rank model (I − diag(rho_c) F̄ Vᵀ) B_c = E_c
    (docs/METHOD.md: V_jp = w_j = d_p A_j / A_p), from the operator's arrays alone."""
    n, off, area = op.n, op.patch_offsets, op.area.astype(np.float64)
    vt = np.zeros((op.k, n))
    for p in range(op.k):
        j = slice(off[p], off[p + 1])
        vt[p, j] = (off[p + 1] - off[p]) * area[j] / area[j].sum()
    fv = op.fbar().astype(np.float64) @ vt
    rho = (op.reflectance if rho is None else rho).astype(np.float64)
    e = np.asarray(e, np.float64)
    return np.stack([np.linalg.solve(np.eye(n) - rho[:, c:c + 1] * fv, e[:, c])
                     for c in range(3)], axis=1)


class Layout(unittest.TestCase):
    def test_struct_mirrors_match_c(self):
        """Every sizeof, and every field's offset and size, of the ctypes mirrors equals the
        C compiler's on include/lrr.h (a field missing from the C struct fails to compile)."""
        cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
        self.assertTrue(cc, "no C compiler (CC) to check the struct layouts with")
        d = tmpdir()
        src, exe = os.path.join(d, "layout.c"), os.path.join(d, "layout")
        with open(src, "w") as f:
            f.write(layout_program())
        subprocess.run(cc.split() + ["-I", os.path.join(SRCDIR, "include"),
                                     "-I", os.path.join(BUILDDIR, "include"), src, "-o", exe],
                       check=True)
        out = subprocess.run([exe], check=True, capture_output=True, text=True).stdout
        checked = 0
        for line in out.splitlines():
            what, kind, value = line.split()
            name, _, field = what.partition(".")
            mirror = lrr._ffi.STRUCTS[name]
            if kind == "sizeof":
                got = ctypes.sizeof(mirror)
            else:
                got = getattr(getattr(mirror, field), "offset" if kind == "offset" else "size")
            self.assertEqual(got, int(value), "%s %s" % (what, kind))
            checked += 1
        self.assertGreaterEqual(checked, 150)
        shutil.rmtree(d)


class AgainstCli(unittest.TestCase):
    """Python's solve against `lrr solve --csv` (rows in the scene's order) on one file."""

    def check_file(self, extra):
        d = tmpdir()
        path = os.path.join(d, "op.lrr")
        out = run_lrr("preprocess", "cornell", "-o", path, "--threads", "2", *extra)
        run_lrr("solve", path, "--csv", os.path.join(d, "b.csv"), "--repeat", "1")
        centre, b_cli = read_csv(os.path.join(d, "b.csv"))
        op = lrr.load(path)
        self.assertEqual(op.n, int(out["n"]))
        self.assertEqual(op.k, int(out["k"]))
        b = op.solve(order="scene")
        # the CSV prints %.9g: floats come back exactly, so the rows are the same subpatches
        np.testing.assert_array_equal(op.to_scene_order(op.centre), centre.astype(np.float32))
        err = max_rel(b, b_cli)
        print("\n  %s: n %d, k %d: max relative difference to lrr solve --csv %.2e"
              % (" ".join(extra), op.n, op.k, err), file=sys.stderr)
        self.assertLess(err, 1e-5)
        shutil.rmtree(d)
        return op, b, b_cli

    def test_uniform(self):
        self.check_file(["--patches", "54", "--levels", "1", "--hemicube", "32"])

    def test_clusters_scene_order(self):
        op, b, b_cli = self.check_file(["--patches", "600", "--levels", "0", "--clusters",
                                        "40", "--adaptive-samples", "64", "--hemicube", "16"])
        self.assertEqual(op.info["hierarchy"], "clusters")
        idx = op.scene_index
        self.assertFalse(np.array_equal(idx, np.arange(op.n)))  # the orders do differ
        np.testing.assert_array_equal(np.sort(idx), np.arange(op.n))  # a permutation
        # operator order is what lrr_solve gives; the CSV holds it permuted
        b_op = op.solve()
        self.assertGreater(max_rel(b_op, b_cli), 1e-2)
        np.testing.assert_array_equal(op.to_scene_order(b_op), b)
        np.testing.assert_array_equal(op.from_scene_order(b), b_op)


class Solve(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.op = lrr.build("cornell", patches=54, levels=1, hemicube=32, seed=2)

    def test_linearity(self):
        """solve(a·E1 + b·E2) = a·solve(E1) + b·solve(E2)"""
        rng = np.random.default_rng(5)
        n = self.op.n
        e1 = rng.random((n, 3), dtype=np.float32)
        e2 = np.zeros((n, 3), np.float32)
        e2[rng.integers(0, n, 7)] = 3.0  # a few emitters: another path of the solver
        a, b = 0.7, 2.5
        lhs = self.op.solve(a * e1 + b * e2)
        rhs = a * self.op.solve(e1).astype(np.float64) + b * self.op.solve(e2)
        err = max_rel(lhs, rhs)
        print("\n  linearity: max relative difference %.2e" % err, file=sys.stderr)
        self.assertLess(err, 1e-5)
        self.assertGreater(float(lhs.min()), 0.0)

    def test_dense_model_solve(self):
        """B equals numpy's dense solve of (I − diag(rho_c) F̄ Vᵀ) B_c = E_c
        (docs/METHOD.md, V_jp = w_j = d_p A_j / A_p), computed from the operator's arrays."""
        op = self.op
        e = np.random.default_rng(9).random((op.n, 3))
        want = dense_model(op, e)
        err = max_rel(op.solve(e), want)
        print("\n  dense model solve: max relative difference %.2e" % err, file=sys.stderr)
        self.assertLess(err, 1e-5)

    def test_layout_keeps_values(self):
        """Panels and rows hold the same F̄ and solve to the dense model's B (to float
        rounding: the kernels sum in different orders)."""
        op = lrr.build("cornell", patches=36, levels=1, hemicube=16)
        self.assertEqual(op.info["layout"], "panels")
        f, b = op.fbar(), op.solve()
        op.set_layout("rows")
        self.assertEqual(op.info["layout"], "rows")
        np.testing.assert_array_equal(op.fbar(), f)
        self.assertLess(max_rel(op.solve(), b), 1e-6)
        self.assertLess(max_rel(b, dense_model(op, op.emission)), 1e-5)
        with self.assertRaises(ValueError):
            op.set_layout("columns")

    def test_set_reflectance_and_save(self):
        """New reflectances give the dense model's B with them; an operator saved and loaded
        back solves to the same bits."""
        op = lrr.build("cornell", patches=36, levels=1, hemicube=16)
        rho = op.reflectance * np.float32([0.5, 1.2, 0.9])
        op.set_reflectance(rho)
        np.testing.assert_array_equal(op.reflectance, rho)
        want = dense_model(op, op.emission, rho)
        b = op.solve()
        self.assertLess(max_rel(b, want), 1e-5)
        path = os.path.join(tmpdir(), "rho.lrr")
        op.save(path)
        back = lrr.load(path)
        np.testing.assert_array_equal(back.solve(), b)

    def test_save_fbar(self):
        """F̄ saved as strips (file version 5) or dense (version 1) loads back bit for bit."""
        op = lrr.build("cornell", patches=36, levels=1, hemicube=16)
        backs = {}
        for fbar, version in (("sparse", 5), ("dense", 1)):
            path = os.path.join(tmpdir(), "fbar-%s.lrr" % fbar)
            op.save(path, fbar=fbar)
            with open(path, "rb") as f:
                self.assertEqual(f.read(12)[8], version)
            backs[fbar] = lrr.load(path)
            np.testing.assert_array_equal(backs[fbar].fbar(), op.fbar())
        np.testing.assert_array_equal(backs["sparse"].solve(), backs["dense"].solve())
        with self.assertRaises(lrr.LrrError):
            op.save(os.path.join(tmpdir(), "bad.lrr"), fbar="csr")

    def test_progress_cancels(self):
        """A progress callback sees done <= total and cancels the build by returning True."""
        seen = []

        def progress(done, total):
            seen.append((done, total))
            return done > 0

        sc = lrr.Scene.builtin("cornell").subdivide(patches=36, levels=1)
        with self.assertRaises(lrr.LrrError) as cm:
            lrr.build_operator(sc, hemicube=16, progress=progress, threads=1)
        self.assertEqual(cm.exception.status, lrr.STATUS["ERR_CANCELLED"])
        self.assertTrue(seen and all(0 <= d <= t for d, t in seen), seen)

    def test_batch_and_paths_agree(self):
        """solve_batch, and each forced path of a solver, give the one-frame full solve."""
        rng = np.random.default_rng(1)
        es = rng.random((3, self.op.n, 3), dtype=np.float32)
        es[2] = 0
        es[2, :4] = 1  # one patch emits: the sparse path can serve it
        full = self.op.solver()
        full.set_path("full")
        want = [full.solve(e) for e in es]
        self.assertEqual(full.last_path, "full")
        for b, w in zip(self.op.solve_batch(es), want):
            self.assertLess(max_rel(b, w), 1e-6)
        sparse = self.op.solver()
        sparse.set_path("sparse")
        self.assertLess(max_rel(sparse.solve(es[2]), want[2]), 1e-5)
        self.assertEqual(sparse.last_path, "sparse")
        with self.assertRaises(lrr.LrrError):
            sparse.set_path("fastest")

    def test_sparse_fbar(self):
        """F̄ read sparse gives the dense B; the info counts F̄'s nonzeros exactly."""
        dense, sparse = self.op.solver(fbar="dense"), self.op.solver(fbar="sparse")
        for s in (dense, sparse):
            s.set_path("full")
        e = np.random.default_rng(2).random((self.op.n, 3), dtype=np.float32)
        self.assertLess(max_rel(sparse.solve(e), dense.solve(e)), 1e-6)
        di, si = dense.info, sparse.info
        self.assertEqual((di["fbar"], si["fbar"]), ("dense", "sparse"))
        f = self.op.fbar()
        self.assertEqual(si["fbar_density"], np.count_nonzero(f) / f.size)
        self.assertEqual(di["fbar_bytes"], di["fbar_dense_bytes"])
        self.assertEqual(di["m_bytes"], 3 * self.op.k ** 2 * 4)
        self.assertEqual(di["m"], "f32")
        with self.assertRaises(lrr.LrrError):
            dense.set_fbar("csr")

    def test_m_f16(self):
        """M − I in binary16: chosen with 16-bit F̄, half M's bytes, B within 16-bit F̄'s own
        rounding of the f32 operator's."""
        k = self.op.k
        s16 = self.op.solver(m="f16")
        s16.set_path("full")
        i = s16.info
        self.assertEqual((i["m"], i["m_bytes"]), ("f16", 3 * k * k * 2 + 3 * k * 4))
        e = np.random.default_rng(3).random((self.op.n, 3), dtype=np.float32)
        want = self.op.solver(m="f32")
        want.set_path("full")
        self.assertLess(max_rel(s16.solve(e), want.solve(e)), 1e-4)
        with self.assertRaises(lrr.LrrError):
            s16.set_m("bf16")

    def test_furnace(self):
        """A sealed box, uniform rho and E (docs/METHOD.md "Exact cases"): B = E/(1 − rho)."""
        rho = np.array([0.9, 0.5, 0.99], np.float32)
        v = box_inward(1.0, 0.7, 1.3)
        sc = lrr.Scene.from_arrays(v, np.tile(rho, (12, 1)), np.full((12, 3), 2.0), "furnace")
        op = lrr.build(sc, patches=48, levels=2, hemicube=64, seed=3)
        b = op.solve()
        want = 2.0 / (1.0 - rho.astype(np.float64))
        err = np.max(np.abs(b / want - 1), axis=0)
        print("\n  furnace: worst relative error %.2e %.2e %.2e" % tuple(err), file=sys.stderr)
        # exact: a closed box's hemicube rows sum to 1 (tests/operator uses 1% at R = 64)
        self.assertTrue(np.all(err < 1e-4), err)


class Build(unittest.TestCase):
    @unittest.skipUnless(built_with("assimp"), "lrr was built without assimp (scene files)")
    def test_scene_file_like_lrr_info(self):
        """A scene file subdivided by build() has the patches `lrr info` reports for the
        same options, and its stored emission is the file's (a lamp: every subpatch emits)."""
        quad = os.path.join(SRCDIR, "tests", "data", "quad.obj")
        info = run_lrr("info", quad, "--patches", "8", "--levels", "1")
        sc = lrr.Scene.open(quad).subdivide(patches=8, levels=1)
        self.assertEqual(sc.info["patches"], int(info["patches"]))
        self.assertEqual(sc.info["subpatches"], int(info["subpatches"]))
        op = lrr.build_operator(sc, hemicube=16, formfactor="raycast")
        self.assertEqual((op.n, op.k), (int(info["subpatches"]), int(info["patches"])))
        self.assertEqual(op.info["formfactor_method"], 2)  # LRR_FORMFACTOR_RAYCAST
        self.assertTrue(np.all(op.emission > 0))
        # a lone emitting quad sees nothing: B = E
        np.testing.assert_array_equal(op.solve(), op.emission)

    def test_options_reach_lrr(self):
        op = lrr.build("cornell-closed", patches=40, levels=0, hemicube=24, seed=7,
                       no_rotation=True, storage="f16")
        i = op.info
        self.assertEqual((i["hemicube_resolution"], i["seed"], i["no_rotation"], i["storage"],
                          i["triangles"]), (24, 7, 1, "f16", 38))
        with self.assertRaises(lrr.LrrError) as cm:
            lrr.build("cornell", patches=36, levels=0, hemicube=7)
        self.assertIn("7", str(cm.exception))
        missing = os.path.join(tmpdir(), "nothing.obj")
        with self.assertRaises(lrr.LrrError) as cm:
            lrr.build(missing)
        self.assertIn(missing, str(cm.exception))


class Verify(unittest.TestCase):
    def test_error_bar_matches_the_cli(self):
        """Operator.verify gives what `lrr preprocess --verify` stores (same draws and paths),
        and the receiver sampling reaches the library."""
        d = tmpdir()
        path = os.path.join(d, "op.lrr")
        out = run_lrr("preprocess", "cornell", "-o", path, "--patches", "54", "--levels", "1",
                      "--hemicube", "32", "--receiver", "centre", "--verify", "64")
        sc = lrr.Scene.open("cornell").subdivide(patches=54, levels=1)
        self.assertEqual(lrr.build_operator(sc, hemicube=16, receiver="area")
                         .info["receiver_sampling"], "area")
        op = lrr.build_operator(sc, hemicube=32, receiver="centre")
        self.assertEqual(op.info["receiver_sampling"], "centre")
        self.assertEqual(op.info["verify_subpatches"], 0)
        v = op.verify(sc, samples=64, seed=1)
        self.assertAlmostEqual(v["rel_l2"] / float(out["verify_rel_l2"]), 1, places=5)
        self.assertEqual(v["subpatches"], int(out["verify_subpatches"]))
        self.assertEqual(v["samples"], 64)
        self.assertGreater(v["noise"], 0)
        self.assertEqual(lrr.load(path).info["verify_rel_l2"], v["rel_l2"])
        with self.assertRaises(lrr.LrrError) as cm:
            op.verify(lrr.Scene.open("cornell").subdivide(patches=60, levels=1))
        self.assertIn("not the one the operator was built from", str(cm.exception))
        shutil.rmtree(d)


class Errors(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.op = lrr.build("cornell", patches=36, levels=0, hemicube=16)

    def test_wrong_shape(self):
        with self.assertRaises(lrr.LrrError) as cm:
            self.op.solve(np.zeros((self.op.n + 1, 3)))
        self.assertEqual(cm.exception.status, lrr.ERR_DIM)
        self.assertIn("(%d, 3)" % self.op.n, str(cm.exception))

    def test_nan_emission_names_the_entry(self):
        e = np.zeros((self.op.n, 3), np.float32)
        e[5, 1] = np.nan
        with self.assertRaises(lrr.LrrError) as cm:
            self.op.solve(e)
        self.assertEqual(cm.exception.status, lrr.ERR_INVALID_ARG)
        self.assertIn("subpatch 5, channel 1", str(cm.exception))  # lrr's own message
        # the next failure carries its own message, not the stale one
        e[5, 1], e[7, 2] = 0, -1
        with self.assertRaises(lrr.LrrError) as cm:
            self.op.solve(e)
        self.assertIn("subpatch 7, channel 2", str(cm.exception))
        self.assertEqual(self.op.solve(np.zeros_like(e)).max(), 0)  # still usable

    def test_error_callback_sees_the_message(self):
        seen = []
        ctx = lrr.Context(on_error=lambda status, message: seen.append((status, message)))
        missing = os.path.join(tmpdir(), "gone.lrr")
        with self.assertRaises(lrr.LrrError) as cm:
            lrr.load(missing, context=ctx)
        self.assertEqual(seen, [(cm.exception.status, str(cm.exception))])
        self.assertIn(missing, seen[0][1])

    def test_missing_file(self):
        missing = os.path.join(tmpdir(), "no-such.lrr")
        with self.assertRaises(lrr.LrrError) as cm:
            lrr.load(missing)
        self.assertEqual(cm.exception.status, lrr.ERR_IO)
        self.assertIn(missing, str(cm.exception))

    def test_corrupt_file(self):
        d = tmpdir()
        path = os.path.join(d, "op.lrr")
        self.op.save(path)
        with open(path, "r+b") as f:
            f.truncate(os.path.getsize(path) // 2)
        with self.assertRaises(lrr.LrrError) as cm:
            lrr.load(path)
        self.assertEqual(cm.exception.status, lrr.STATUS["ERR_CORRUPT"])
        self.assertIn(path, str(cm.exception))

    def test_bad_light_names_the_field(self):
        with self.assertRaises(lrr.LrrError) as cm:
            self.op.direct_light([lrr.lights.Sun((0, 1, 0), (1, 1, 1)),
                                  lrr.lights.Point((0, 0, 0), (1, -2, 1))])
        self.assertEqual(cm.exception.status, lrr.ERR_INVALID_ARG)
        self.assertIn("light 1", str(cm.exception))
        self.assertIn("rgb", str(cm.exception))

    def test_closed_objects(self):
        """After close() a call raises instead of handing lrr a NULL handle; an operator
        dropped with its own solver and lighting alive (a reference cycle) is freed without
        a crash, solver and lighting first."""
        import gc
        op = lrr.build("cornell", patches=36, levels=0, hemicube=16)
        op.solve()
        op.direct_light(lrr.lights.Sun((0, -1, 0), (1, 1, 1)))
        solver = op.solver()
        solver.close()
        with self.assertRaises(lrr.LrrError) as cm:
            solver.solve()
        self.assertIn("Solver: used after close()", str(cm.exception))
        del op, solver
        gc.collect()
        with lrr.build("cornell", patches=36, levels=0, hemicube=16) as op2:
            self.assertEqual(op2.n, 36)
        with self.assertRaises(lrr.LrrError):
            op2.solve()

    def test_bad_scene_names_the_face(self):
        v = quad_up(1.0)
        v[1, 4] = np.inf
        with self.assertRaises(lrr.LrrError) as cm:
            lrr.Scene.from_arrays(v, np.full((2, 3), 0.5), np.zeros((2, 3)), "inf-quad")
        self.assertIn("inf-quad", str(cm.exception))


class Lights(unittest.TestCase):
    def test_point_inverse_square(self):
        """On an unoccluded floor facing up, a point light of intensity I at p gives
        E_i = rho I cos θ / r² = rho I h / r³ (h its height) at every subpatch, and doubling
        the height quarters the light at the subpatch right below it."""
        rho = np.array([0.5, 0.25, 0.8])
        sc = lrr.Scene.from_arrays(quad_up(4.0), np.tile(rho, (2, 1)), np.zeros((2, 3)))
        op = lrr.build(sc, patches=32, levels=1, hemicube=16)
        x = op.centre.astype(np.float64)
        inten = np.array([10.0, 20.0, 5.0])
        below = 17  # the light stands over this subpatch's centre
        e_below = {}
        for h in (1.0, 2.0):
            p = x[below] + (0, h, 0)
            e = op.direct_light([lrr.lights.Point(p, inten)])
            r = np.linalg.norm(x - p, axis=1)
            want = rho * inten * (h / r ** 3)[:, None]
            self.assertLess(max_rel(e, want), 1e-5)
            e_below[h] = e[below].astype(np.float64)
            # the same light as a dict
            e2 = op.direct_light([{"kind": "point", "position": p, "rgb": inten}])
            np.testing.assert_array_equal(e, e2)
        ratio = e_below[1.0] / e_below[2.0]
        print("\n  inverse square: E(h)/E(2h) below the light %.7f %.7f %.7f" % tuple(ratio),
              file=sys.stderr)
        np.testing.assert_allclose(ratio, 4.0, rtol=1e-6)

    def test_sun_cosine(self):
        """A sun at 60° from the normal gives E = rho · rgb · cos 60° everywhere."""
        rho = np.array([0.5, 0.5, 0.5])
        sc = lrr.Scene.from_arrays(quad_up(2.0), np.tile(rho, (2, 1)), np.zeros((2, 3)))
        op = lrr.build(sc, patches=8, levels=0, hemicube=16)
        e = op.direct_light(lrr.lights.Sun((np.sin(np.pi / 3), np.cos(np.pi / 3), 0),
                                           (2, 2, 2)))
        np.testing.assert_allclose(e, 0.5 * 2 * 0.5, rtol=1e-5)

    def test_lighting_tolerance(self):
        """Lighting(op, tolerance): fewer rays, each light within its error budget (the
        area-weighted L2 norm per channel); a tolerance outside [0, 1) is refused."""
        op = lrr.build("cornell-closed", patches=300, levels=1, hemicube=8)
        light = [lrr.lights.Point((150, 450, 200), (1e5, 1e5, 1e5))]
        exact, budget = lrr.Lighting(op), lrr.Lighting(op, tolerance=0.05)
        x, e = exact.direct(light), budget.direct(light)
        a = np.asarray(op.area, dtype=np.float64)[:, None]
        d, x = e.astype(np.float64) - x, x.astype(np.float64)
        err = np.sqrt((a * d ** 2).sum(0) / (a * x ** 2).sum(0))
        self.assertTrue((err <= 0.05).all(), err)
        self.assertLess(budget.rays, exact.rays)
        with self.assertRaises(lrr.LrrError) as cm:
            budget.set_tolerance(1.5)
        self.assertIn("tolerance", str(cm.exception))
        exact.close()
        budget.close()


def parse_glb(path):
    """(json, bin) of a binary glTF, checking its header and chunk framing."""
    with open(path, "rb") as f:
        data = f.read()
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    assert magic == b"glTF" and version == 2 and length == len(data), (magic, version, length)
    jlen, jtype = struct.unpack_from("<I4s", data, 12)
    assert jtype == b"JSON"
    doc = json.loads(data[20:20 + jlen])
    blen, btype = struct.unpack_from("<I4s", data, 20 + jlen)
    assert btype == b"BIN\0"
    return doc, data[28 + jlen:28 + jlen + blen]


def accessor(doc, binary, index):
    a = doc["accessors"][index]
    view = doc["bufferViews"][a["bufferView"]]
    width = {"VEC3": 3, "VEC4": 4}[a["type"]]
    assert a["componentType"] == 5126  # float
    start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    stride = view.get("byteStride", 4 * width)
    rows = [struct.unpack_from("<%df" % width, binary, start + i * stride)
            for i in range(a["count"])]
    return np.array(rows)


class Export(unittest.TestCase):
    def test_glb_colours(self):
        """A constant radiosity B = (0.3, 2, 0.5): every vertex's COLOR_0 is
        min(1, B × exposure) with alpha 1, and _RADIOSITY is B (the area-weighted mean of
        equal values); the counts are those of export_info."""
        op = lrr.build("cornell", patches=36, levels=1, hemicube=16)
        b = np.tile(np.float32([0.3, 2.0, 0.5]), (op.n, 1))
        d = tmpdir()
        path = os.path.join(d, "lit.glb")
        for exposure, colour in ((1.0, [0.3, 1.0, 0.5, 1.0]), (0.25, [0.075, 0.5, 0.125, 1])):
            op.export_gltf(b, path, exposure=exposure)
            doc, binary = parse_glb(path)
            info = op.export_info(b, exposure=exposure)
            prims = doc["meshes"][0]["primitives"]
            colours = {p["attributes"]["COLOR_0"] for p in prims}
            self.assertEqual(len(colours), 1)  # one vertex set shared by the primitives
            attrs = prims[0]["attributes"]
            self.assertEqual(doc["accessors"][attrs["COLOR_0"]]["type"], "VEC4")
            col = accessor(doc, binary, attrs["COLOR_0"])
            self.assertEqual(len(col), info["vertices"])
            np.testing.assert_allclose(col, np.tile(colour, (len(col), 1)), rtol=1e-6)
            rad = accessor(doc, binary, attrs["_RADIOSITY"])
            np.testing.assert_allclose(rad, np.tile([0.3, 2.0, 0.5], (len(rad), 1)),
                                       rtol=1e-6)
            indices = sum(doc["accessors"][p["indices"]]["count"] for p in prims)
            self.assertEqual(indices, 3 * info["triangles"])
            self.assertEqual(len(prims), info["materials"])
        # the PLY of the same mesh: its header counts the same vertices and faces
        ply = os.path.join(d, "lit.ply")
        op.export_ply(b, ply)
        with open(ply, "rb") as f:
            head = f.read(4096).split(b"end_header")[0].decode()
        self.assertIn("element vertex %d" % info["vertices"], head)
        self.assertIn("element face %d" % info["triangles"], head)
        shutil.rmtree(d)

    def test_negative_radiosity_names_the_subpatch(self):
        op = lrr.build("cornell", patches=36, levels=0, hemicube=16)
        b = np.ones((op.n, 3), np.float32)
        b[3, 0] = -1
        path = os.path.join(tmpdir(), "never.glb")
        with self.assertRaises(lrr.LrrError) as cm:
            op.export_gltf(b, path)
        self.assertIn("subpatch 3", str(cm.exception))
        self.assertFalse(os.path.exists(path))


class Example(unittest.TestCase):
    def test_relight_example(self):
        """examples/relight.py runs and writes a glb that parses and a PNG of the asked size."""
        d = tmpdir()
        script = os.path.join(SRCDIR, "examples", "relight.py")
        pkg = os.path.dirname(os.path.dirname(os.path.abspath(lrr.__file__)))
        r = subprocess.run([sys.executable, script, "--out", d, "--patches", "54",
                            "--levels", "1", "--hemicube", "32"],
                           capture_output=True, text=True, env=dict(os.environ, PYTHONPATH=pkg))
        self.assertEqual(r.returncode, 0, r.stderr)
        print("\n" + r.stdout, file=sys.stderr)
        doc, _ = parse_glb(os.path.join(d, "relit.glb"))
        self.assertIn("COLOR_0", doc["meshes"][0]["primitives"][0]["attributes"])
        with open(os.path.join(d, "relit.png"), "rb") as f:
            png = f.read(24)
        self.assertEqual(png[:8], b"\x89PNG\r\n\x1a\n")
        self.assertEqual(struct.unpack(">II", png[16:24]), (320, 320))
        # the table: as the light moves from the green wall (x = 0) to the red one
        # (x = 556), the red wall brightens and the green one darkens
        rows = [l.split() for l in r.stdout.splitlines() if l.startswith("light x=")]
        self.assertEqual(len(rows), 4)
        red, green = [float(w[5]) for w in rows], [float(w[6]) for w in rows]
        self.assertEqual(red, sorted(red))
        self.assertEqual(green, sorted(green, reverse=True))
        shutil.rmtree(d)


if __name__ == "__main__":
    unittest.main()
