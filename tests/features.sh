#!/bin/sh
# The optional features (configure --without-assimp, --without-cgal, --without-openexr,
# --disable-opencl, --disable-viewer): `lrr --version` lists what configure found
# (LRR_FEATURES, from configure), and each feature does what that list says. One built
# works (a scene file imports, lrr check runs, an .exr probe loads and an .exr picture is
# written); one left out fails with exit 1 and the error names the file and "lrr was built
# without X", writing nothing. The minimal build of .ci/run checks every error this way.
# Environment: LRR_BIN, LRR_TEST_TMP, LRR_DATA_DIR, LRR_FEATURES (as make check sets them).
LRR=${LRR_BIN:-./lrr}
DATA=${LRR_DATA_DIR:-data}
checks=0
failures=0
pass() { checks=$((checks + 1)); echo "PASS: $1"; }
fail() { checks=$((checks + 1)); failures=$((failures + 1)); echo "FAIL: $1"; }
T=$(mktemp -d "${LRR_TEST_TMP:-/tmp}/features.XXXXXX") || exit 1
trap 'rm -rf "$T"' EXIT
run() { "$LRR" "$@" >"$T/out" 2>"$T/err"; rc=$?; }

run --version
features=$(sed -n 's/^features: *//p' "$T/out")
if [ "$rc" -eq 0 ] && grep -q '^features:' "$T/out"; then
    pass "lrr --version lists the features: '$features'"
else
    fail "lrr --version (exit $rc) has no features line"
fi
if [ -n "${LRR_FEATURES+set}" ]; then
    # configure's list (Makefile.am) against the library's and the tool's #ifs
    if [ "$(echo $features)" = "$(echo $LRR_FEATURES)" ]; then
        pass "the features are configure's ('$LRR_FEATURES')"
    else
        fail "lrr --version lists '$features', configure found '$LRR_FEATURES'"
    fi
fi
has() { case " $features " in *" $1 "*) return 0 ;; esac; return 1; }

# without FEATURE NAME FILE WHAT: the last run failed with exit 1 naming FILE and NAME.
without() {
    if [ "$rc" -eq 1 ] && grep -q "$3.*lrr was built without $2" "$T/err"; then
        pass "without $1: $4 fails: $(head -n 1 "$T/err")"
    else
        fail "without $1: $4: exit $rc, stderr: $(head -n 1 "$T/err")"
    fi
}

# assimp: scene files
run info "$DATA/cornell-box.obj"
if has assimp; then
    if [ "$rc" -eq 0 ] && grep -qx 'triangles: 36' "$T/out"; then
        pass "assimp: lrr info cornell-box.obj reads 36 triangles"
    else
        fail "assimp: lrr info cornell-box.obj (exit $rc)"
    fi
else
    without assimp assimp 'cornell-box.obj' "lrr info cornell-box.obj"
    run info cornell
    if [ "$rc" -eq 0 ] && grep -qx 'triangles: 36' "$T/out"; then
        pass "without assimp: the built-in cornell still loads (36 triangles)"
    else
        fail "without assimp: lrr info cornell (exit $rc)"
    fi
fi

# CGAL: lrr check
run check cornell
if has cgal; then
    if [ "$rc" -eq 0 ] && grep -qx 'intersecting_pairs: 0' "$T/out"; then
        pass "cgal: lrr check cornell finds no intersecting pairs"
    else
        fail "cgal: lrr check cornell (exit $rc)"
    fi
else
    without cgal CGAL 'cornell: scene check' "lrr check cornell"
fi

# OpenEXR: .exr probes in, .exr pictures out
run probe "$DATA/probes/studio.exr" --method sh9 --normals 16
if has openexr; then
    if [ "$rc" -eq 0 ]; then pass "openexr: lrr probe studio.exr"; else fail "openexr: lrr probe studio.exr (exit $rc)"; fi
else
    without openexr OpenEXR 'studio.exr' "lrr probe studio.exr"
    run probe "$DATA/probes/studio.hdr" --method sh9 --normals 16
    if [ "$rc" -eq 0 ]; then
        pass "without openexr: the .hdr probe still loads"
    else
        fail "without openexr: lrr probe studio.hdr (exit $rc)"
    fi
fi
run preprocess cornell -o "$T/c.lrr" --patches 30 --levels 1 --hemicube 32 --threads 2
if [ "$rc" -ne 0 ]; then
    fail "preprocess cornell (exit $rc): $(head -n 1 "$T/err")"
else
    run render "$T/c.lrr" -o "$T/pic.exr" --width 16 --height 8
    sig=$(od -An -tx1 -N4 "$T/pic.exr" 2>/dev/null | tr -d ' \n')
    if has openexr; then
        if [ "$rc" -eq 0 ] && [ "$sig" = 762f3101 ]; then
            pass "openexr: lrr render -o pic.exr writes OpenEXR"
        else
            fail "openexr: lrr render -o pic.exr (exit $rc), signature '$sig'"
        fi
    else
        without openexr OpenEXR 'pic.exr' "lrr render -o pic.exr"
        if [ -e "$T/pic.exr" ]; then fail "without openexr: pic.exr was written"; fi
    fi
fi

echo "features: $checks checks, $failures failed"
[ "$failures" -eq 0 ]
