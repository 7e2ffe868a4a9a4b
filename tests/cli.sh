#!/bin/sh
# Tests of the `lrr` command-line tool, run by `make check`.
# Environment: LRR_BIN (the built lrr; default ./lrr), LRR_TEST_TMP (a writable directory).
# Prints one line per check; exits 0 when all pass, 1 otherwise.
set -u

LRR=${LRR_BIN:-./lrr}
TMPROOT=${LRR_TEST_TMP:-${TMPDIR:-/tmp}}
if [ ! -x "$LRR" ]; then
    echo "FAIL: LRR_BIN='$LRR' is not an executable"
    exit 1
fi
# Most checks read scene files, .exr probes and pictures or run lrr check: a build without
# one of those (configure --without-X) skips them all; tests/features.sh checks its errors.
for feature in assimp cgal openexr; do
    case " $("$LRR" --version | sed -n 's/^features://p') " in
        *" $feature "*) ;;
        *) echo "SKIP: lrr was built without $feature (tests/features.sh covers that build)"; exit 77 ;;
    esac
done
T=$(mktemp -d "$TMPROOT/cli.XXXXXX") || { echo "FAIL: cannot create a directory in $TMPROOT"; exit 1; }

failures=0
checks=0
pass() { checks=$((checks + 1)); echo "PASS: $1"; }
fail() { checks=$((checks + 1)); failures=$((failures + 1)); echo "FAIL: $1"; }

# LRR_VALGRIND=1 (make check-valgrind, .ci/run): every lrr invocation runs under valgrind
# memcheck. A memory error or a definite or indirect leak makes that invocation exit 99,
# which fails its check, and the last check lists every invocation whose valgrind log is not
# empty. tests/valgrind.supp suppresses third-party noise only. OpenCL is off under valgrind
# (OCL_ICD_VENDORS names an empty directory, so the OpenCL checks take their documented
# "no OpenCL platform" branch): PoCL compiles its kernels with LLVM at run time, which
# valgrind runs for minutes and reports JIT noise in; the OpenCL backend is checked by the
# unit tests, in both ordinary and sanitizer builds, instead.
VG_LOGS=""
if [ "${LRR_VALGRIND:-0}" != 0 ]; then
    if ! command -v valgrind >/dev/null 2>&1; then
        echo "FAIL: LRR_VALGRIND is set but valgrind is not installed"
        exit 1
    fi
    VG_SUPP=${LRR_VALGRIND_SUPP:-$(dirname "$0")/valgrind.supp}
    # an uninstalled lrr is a libtool wrapper script: libtool --mode=execute hands valgrind
    # the real binary with the library path set
    VG_LIBTOOL=${LRR_LIBTOOL:-$(dirname "$LRR")/libtool}
    VG_EXEC=""
    [ -x "$VG_LIBTOOL" ] && VG_EXEC="$VG_LIBTOOL"
    VG_LOGS="$T/valgrind"
    mkdir "$VG_LOGS" "$T/no-icd-valgrind"
    OCL_ICD_VENDORS="$T/no-icd-valgrind"
    export OCL_ICD_VENDORS
    echo "valgrind: $(valgrind --version), suppressions $VG_SUPP, OpenCL off"
fi

# lrr_exec ARGS...: runs lrr (under valgrind with LRR_VALGRIND).
lrr_exec() {
    if [ -z "$VG_LOGS" ]; then
        "$LRR" "$@"
        return
    fi
    set -- valgrind --quiet --error-exitcode=99 --leak-check=full \
        --errors-for-leak-kinds=definite,indirect --show-leak-kinds=definite,indirect \
        --suppressions="$VG_SUPP" --log-file="$VG_LOGS/%p.log" "$LRR" "$@"
    if [ -n "$VG_EXEC" ]; then
        "$VG_EXEC" --mode=execute "$@"
    else
        "$@"
    fi
}

# run ARGS...: runs lrr, stdout in $T/out, stderr in $T/err, exit status in $rc.
run() {
    lrr_exec "$@" >"$T/out" 2>"$T/err"
    rc=$?
}

# value KEY: the value of a "key: value" line of the last stdout.
value() { sed -n "s/^$1: //p" "$T/out" | head -n 1; }

show_err() { sed 's/^/    stderr: /' "$T/err" | head -n 5; }

# expect_rc WANT DESCRIPTION
expect_rc() {
    if [ "$rc" -eq "$1" ]; then pass "$2 (exit $rc)"; else fail "$2: exit $rc, expected $1"; show_err; fi
}

# ---------------------------------------------------------------- help and version
run --help
if [ "$rc" -eq 0 ] && grep -q 'preprocess' "$T/out" && grep -q -- '--version' "$T/out"; then
    pass "lrr --help lists the commands"
else
    fail "lrr --help (exit $rc)"
fi

run --version
if [ "$rc" -eq 0 ] && grep -Eq '^lrr [0-9]+\.[0-9]+\.[0-9]+$' "$T/out"; then
    pass "lrr --version prints $(cat "$T/out")"
else
    fail "lrr --version (exit $rc): $(cat "$T/out")"
fi

# help_mentions COMMAND OPTION...: COMMAND --help exits 0 and names every OPTION.
help_mentions() {
    cmd=$1
    shift
    run "$cmd" --help
    missing=""
    for opt in "$@"; do
        grep -q -- "$opt" "$T/out" || missing="$missing $opt"
    done
    if [ "$rc" -eq 0 ] && [ -z "$missing" ]; then
        pass "lrr $cmd --help mentions $*"
    else
        fail "lrr $cmd --help (exit $rc), missing:$missing"
    fi
}
help_mentions info --max-patch-area --patches --levels cornell
help_mentions preprocess -o --hemicube --seed --threads --progress --patches --levels --storage --no-rotation \
    --memory-budget "physical memory" --formfactor raycast --receiver --verify verify_rel_l2 \
    "more than 2000"
help_mentions info FILE.lrr verify_noise
help_mentions solve --csv --emission-scale --repeat --path --backend LRR_OPENCL_DEVICE --probe --sources \
    --probe-method --probe-scale --no-scene-emission direct_light_seconds
help_mentions render -o --width --height --exposure --emission-scale --probe --sources --probe-method \
    --eye --target --up --fov --format .exr linear
help_mentions export -o --format --subpatches --exposure --emission-scale COLOR_0 KHR_materials_unlit \
    radiosity_r
help_mentions demo --out --memory-budget
help_mentions reference --method jacobi gauss-seidel southwell direct path-trace --samples --tol --max-iterations \
    --memory-budget --csv --hemicube --seed --threads --progress --patches --levels
help_mentions compare rel_l2 max_rel mean_abs

# ---------------------------------------------------------------- command-line errors
run info cornell --bogus-option
if [ "$rc" -eq 2 ] && grep -q -- '--bogus-option' "$T/err"; then
    pass "unknown option: exit 2 naming it"
else
    fail "unknown option: exit $rc, stderr: $(cat "$T/err")"
fi

run frobnicate
if [ "$rc" -eq 2 ] && grep -q 'frobnicate' "$T/err"; then
    pass "unknown command: exit 2 naming it"
else
    fail "unknown command: exit $rc, stderr: $(cat "$T/err")"
fi

run info cornell --levels abc
if [ "$rc" -eq 2 ] && grep -q -- "--levels: 'abc' is not an integer" "$T/err"; then
    pass "--levels abc: exit 2, $(cat "$T/err")"
else
    fail "--levels abc: exit $rc, stderr: $(cat "$T/err")"
fi

run info cornell --levels 11
if [ "$rc" -eq 2 ] && grep -q 'out of range' "$T/err"; then
    pass "--levels 11: exit 2, out of range"
else
    fail "--levels 11: exit $rc, stderr: $(cat "$T/err")"
fi

run info cornell --patches 5x
expect_rc 2 "--patches 5x is rejected"
run info cornell --patches -3
expect_rc 2 "--patches -3 is rejected"
run info cornell --patches 10 --max-patch-area 100
expect_rc 2 "--patches with --max-patch-area is rejected"
run info cornell --levels
expect_rc 2 "--levels without a value is rejected"
run info
expect_rc 2 "info without SCENE is rejected"
run preprocess cornell
expect_rc 2 "preprocess without -o is rejected"
run solve nothing.lrr --emission-scale -1
expect_rc 2 "--emission-scale -1 is rejected"
run solve nothing.lrr --emission-scale nan
expect_rc 2 "--emission-scale nan is rejected"
run solve nothing.lrr --repeat 0
expect_rc 2 "--repeat 0 is rejected"
run reference cornell
expect_rc 2 "reference without --method is rejected"
run reference cornell --method newton
if [ "$rc" -eq 2 ] && grep -q 'newton' "$T/err" && grep -q 'jacobi, gauss-seidel, southwell, direct' "$T/err"; then
    pass "--method newton: exit 2 listing the four methods"
else
    fail "--method newton: exit $rc, stderr: $(cat "$T/err")"
fi
run reference cornell --method jacobi --tol 1
expect_rc 2 "--tol 1 is rejected"
run reference cornell --method direct --memory-budget 0
expect_rc 2 "--memory-budget 0 is rejected"
run compare only-one.csv
expect_rc 2 "compare with one file is rejected"
run reference cornell --method path-trace --samples 1
expect_rc 2 "--samples 1 is rejected (no standard error)"
run reference cornell --method jacobi --samples 8
expect_rc 2 "--samples without --method path-trace is rejected"

# ---------------------------------------------------------------- info
run info cornell --patches 50 --levels 1
patches=$(value patches)
subpatches=$(value subpatches)
if [ "$rc" -eq 0 ] && [ "$(value triangles)" = 36 ] && [ -n "$patches" ] &&
    [ "$patches" -ge 36 ] && [ "$subpatches" = $((4 * patches)) ] && [ "$(value d)" = 4 ]; then
    pass "info cornell: triangles 36, patches $patches, subpatches $subpatches = 4 x patches"
else
    fail "info cornell (exit $rc): triangles '$(value triangles)', patches '$patches', subpatches '$subpatches'"
    show_err
fi

missing_scene="$T/no-such-dir/scene.obj"
run info "$missing_scene"
if [ "$rc" -eq 1 ] && grep -qF "$missing_scene" "$T/err"; then
    pass "missing scene file: exit 1 naming the path"
else
    fail "missing scene file: exit $rc, stderr: $(cat "$T/err")"
fi

# ---------------------------------------------------------------- preprocess
LRRFILE="$T/small.lrr"
run preprocess cornell -o "$LRRFILE" --patches 30 --levels 1 --hemicube 32 --threads 2
n=$(value n)
if [ "$rc" -eq 0 ] && [ -s "$LRRFILE" ] && [ -n "$n" ] && [ "$n" -gt 0 ] &&
    [ "$(value output)" = "$LRRFILE" ] && [ "$(value hemicube)" = 32 ]; then
    pass "preprocess writes $(wc -c <"$LRRFILE" | tr -d ' ') bytes, n = $n, k = $(value k)"
else
    fail "preprocess (exit $rc)"
    show_err
fi
leftover=""
for f in "$T"/*tmp*; do [ -e "$f" ] && leftover="$leftover $f"; done
if [ -n "$leftover" ]; then fail "preprocess left temporary files:$leftover"; else pass "preprocess left no temporary file"; fi

# the light-leak indicator: the share of hemicube pixels seeing back faces, and the worst
# triangles. A cube with all faces outward: no receiver sees a back. The same cube with face
# 5 flipped inwards: that face sees only backs (share 1), 1 of 12 triangles → 1/12.
# cornell-closed is not 0: the floor under the closed blocks and the ceiling over the
# one-sided light (0.05 mm under it) see back faces; they are hidden and receive nothing.
TDATA=${LRR_SRCDIR:-.}/tests/data
run preprocess "$TDATA/check_box.obj" -o "$T/leak.lrr" --levels 1 --hemicube 16 --threads 2
if [ "$rc" -eq 0 ] && [ "$(value back_face_share)" = 0 ] && ! grep -q '^worst_back_face:' "$T/out"; then
    pass "preprocess: back_face_share 0 for a consistently oriented cube"
else
    fail "back_face_share of check_box.obj (exit $rc): '$(value back_face_share)'"; show_err
fi
run preprocess "$TDATA/check_box_flipped.obj" -o "$T/leak.lrr" --levels 1 --hemicube 16 --threads 2
if [ "$rc" -eq 0 ] && [ "$(value back_face_share)" = 0.0833333 ] &&
    [ "$(grep -c '^worst_back_face:' "$T/out")" = 1 ] && [ "$(value worst_back_face)" = "5 1" ]; then
    pass "preprocess: a flipped face gives back_face_share $(value back_face_share), names 'worst_back_face: 5 1'"
else
    fail "back_face_share of check_box_flipped.obj (exit $rc): $(grep back_face "$T/out" | tr '\n' ' ')"; show_err
fi
run preprocess cornell-closed -o "$T/leak.lrr" --patches 30 --levels 1 --hemicube 32 --threads 2
share=$(value back_face_share)
if [ "$rc" -eq 0 ] && awk -v s="$share" 'BEGIN { exit !(s > 0 && s < 0.05) }' &&
    ! sed -n 's/^worst_back_face: //p' "$T/out" | awk '$1 > 3 { bad = 1 } END { exit !bad }'; then
    pass "preprocess cornell-closed: back_face_share $share, only floor/ceiling triangles named"
else
    fail "back_face_share of cornell-closed (exit $rc): $(grep back_face "$T/out" | tr '\n' ' ')"; show_err
fi

# --receiver: where the hemicubes look from (auto: the areas where rays are cast); area with
# the rasteriser is refused by the library, naming both.
for rv in auto:raster:centre auto:raycast:area centre:raycast:centre area:auto:area; do
    rv_opt=${rv%%:*} rv_ff=${rv#*:} rv_want=${rv##*:}
    rv_ff=${rv_ff%%:*}
    run preprocess cornell --patches 24 --levels 1 --hemicube 16 --receiver "$rv_opt" \
        --formfactor "$rv_ff" -o "$T/rv.lrr"
    if [ "$rc" -eq 0 ] && [ "$(value receiver)" = "$rv_want" ]; then
        pass "preprocess --receiver $rv_opt --formfactor $rv_ff prints receiver: $rv_want"
    else
        fail "preprocess --receiver $rv_opt --formfactor $rv_ff (exit $rc, receiver: $(value receiver))"
        show_err
    fi
done
run preprocess cornell --patches 24 --levels 1 --receiver area --formfactor raster -o "$T/rv.lrr"
if [ "$rc" -eq 1 ] && grep -q 'LRR_RECEIVER_AREA needs rays' "$T/err"; then
    pass "preprocess --receiver area --formfactor raster: refused, naming why"
else
    fail "preprocess --receiver area --formfactor raster: exit $rc"; show_err
fi
run preprocess cornell --receiver middle -o "$T/rv.lrr"
expect_rc 2 "preprocess --receiver middle is a usage error"

# --verify [S]: the error bar, printed and kept in the file (lrr info FILE.lrr); S as the
# next word or after '='; a coarse operator from the centres is ~10% off the path tracer.
for form in "--verify 128" "--verify=128"; do
    # shellcheck disable=SC2086 # form is two words or one
    run preprocess cornell --patches 54 --levels 1 --hemicube 32 --receiver centre $form \
        -o "$T/verify.lrr"
    e=$(value verify_rel_l2) noise=$(value verify_noise)
    if [ "$rc" -eq 0 ] && [ "$(value verify_subpatches)" -gt 100 ] &&
        [ "$(value verify_samples)" = 128 ] && [ "$(value verify_emission)" = scene ] &&
        awk -v e="$e" -v s="$noise" 'BEGIN { exit !(e > 0.03 && e < 0.3 && s > 0 && s < e) }'
    then
        pass "preprocess $form: verify_rel_l2 $e, verify_noise $noise"
    else
        fail "preprocess $form: exit $rc, verify_rel_l2 '$e', verify_noise '$noise'"; show_err
    fi
done
run info "$T/verify.lrr"
if [ "$rc" -eq 0 ] && [ "$(value verify_rel_l2)" = "$e" ] && [ "$(value k)" = 54 ] &&
    [ "$(value receiver)" = centre ]; then
    pass "lrr info FILE.lrr prints the stored error bar (verify_rel_l2 $e)"
else
    fail "lrr info FILE.lrr: exit $rc, verify_rel_l2 '$(value verify_rel_l2)'"; show_err
fi
run preprocess cornell --patches 54 --levels 1 --verify 1 -o "$T/verify.lrr"
expect_rc 2 "preprocess --verify 1 is a usage error (two estimates of 2 paths or more)"

# No hierarchy option on a scene of more than 2000 triangles: clusters, K = 2000 or what the
# memory budget allows (here ~70), said on stderr; the refusal of a build that does not fit
# names --clusters.
awk 'BEGIN { print "mtllib none.mtl"; for (i = 0; i <= 41; i++) for (j = 0; j <= 25; j++)
             printf "v %d 0 %d\n", i, j;
             for (i = 0; i < 41; i++) for (j = 0; j < 25; j++) { a = i * 26 + j + 1;
               printf "f %d %d %d\nf %d %d %d\n", a, a + 1, a + 27, a, a + 27, a + 26 } }' \
    > "$T/grid.obj"
run preprocess "$T/grid.obj" -o "$T/grid.lrr" --hemicube 8 --memory-budget 513
if [ "$rc" -eq 0 ] && [ "$(value hierarchy)" = clusters ] &&
    grep -q '2050 triangles: --clusters [0-9]* --hemicube 8, the most clusters that fit --memory-budget 513' "$T/err"
then
    pass "preprocess of 2050 triangles, no options: $(grep -o -- '--clusters [0-9]*' "$T/err"), k = $(value k)"
else
    fail "preprocess of 2050 triangles with no options: exit $rc, hierarchy $(value hierarchy)"
    show_err
fi
run preprocess "$T/grid.obj" -o "$T/grid.lrr" --patches 2050 --levels 2 --hemicube 8 \
    --memory-budget 64
if [ "$rc" -eq 1 ] && grep -q 'use --clusters K' "$T/err" &&
    grep -q 'LRR_HIERARCHY_CLUSTER' "$T/err"; then
    pass "a quadtree build over the budget is refused naming --clusters"
else
    fail "quadtree build over the budget: exit $rc"; show_err
fi

# --memory-budget: a build that does not fit is refused before it starts, naming the MiB it
# needs (n = 7968, k = 498: F̄ alone is 15 MiB); the small build above fits in 1 MiB.
BIGSCENE="cornell --patches 500 --levels 2 --hemicube 32"
# shellcheck disable=SC2086 # BIGSCENE is a list of arguments
run preprocess $BIGSCENE --memory-budget 1 -o "$T/budget.lrr"
need=$(sed -n 's/.* needs \([0-9.]*\) MiB.*/\1/p' "$T/err" | head -n 1)
if [ "$rc" -eq 1 ] && grep -q 'memory budget exceeded' "$T/err" && grep -q 'n = 7968' "$T/err" &&
    grep -q 'more than the memory budget of 1.0 MiB' "$T/err" &&
    awk -v x="$need" 'BEGIN { exit !(x + 0 > 15 && x + 0 < 64) }' && [ ! -e "$T/budget.lrr" ]; then
    pass "preprocess --memory-budget 1: exit 1 before the build, needs $need MiB"
else
    fail "preprocess --memory-budget 1: exit $rc, need '$need', stderr: $(cat "$T/err")"
fi
run preprocess cornell -o "$T/budget.lrr" --patches 30 --levels 1 --hemicube 32 --memory-budget 1
if [ "$rc" -eq 0 ] && [ -s "$T/budget.lrr" ]; then
    pass "preprocess --memory-budget 1 of a small scene: builds"
else
    fail "preprocess --memory-budget 1, small scene: exit $rc"; show_err
fi
run preprocess cornell -o "$T/budget0.lrr" --patches 30 --levels 1 --hemicube 32 --memory-budget 0
expect_rc 0 "preprocess --memory-budget 0 (no limit)"
run preprocess cornell -o "$T/budget.lrr" --memory-budget lots
expect_rc 2 "preprocess --memory-budget lots is a usage error"
run demo --out "$T/demo" --memory-budget 1
if [ "$rc" -eq 1 ] && grep -q 'memory budget exceeded' "$T/err" && grep -q 'needs [0-9.]* MiB' "$T/err" &&
    [ ! -e "$T/demo/cornell.lrr" ]; then
    pass "demo --memory-budget 1: exit 1, $(grep -o 'needs [0-9.]* MiB' "$T/err" | head -n 1)"
else
    fail "demo --memory-budget 1: exit $rc, stderr: $(cat "$T/err")"
fi

# ---------------------------------------------------------------- solve
CSV="$T/b.csv"
run solve "$LRRFILE" --csv "$CSV" --repeat 3
mean1=$(value mean_b_r)
if [ "$rc" -eq 0 ] && [ "$(value n)" = "$n" ] && [ -n "$(value solve_ms)" ] && [ -n "$mean1" ]; then
    pass "solve prints n = $n, solve_ms = $(value solve_ms), mean_b_r = $mean1"
else
    fail "solve (exit $rc)"
    show_err
fi

header='subpatch,patch,area,cx,cy,cz,nx,ny,nz,b_r,b_g,b_b'
if [ -f "$CSV" ] && [ "$(head -n 1 "$CSV")" = "$header" ]; then
    pass "CSV header is exact"
else
    fail "CSV header: '$(head -n 1 "$CSV" 2>/dev/null)'"
fi
[ -f "$CSV" ] || : >"$CSV" # a missing CSV has already failed above; keep the checks quiet
rows=$(($(wc -l <"$CSV") - 1))
if [ "$rows" = "$n" ]; then pass "CSV has n = $n rows"; else fail "CSV has $rows rows, expected $n"; fi

# Every b is a finite number >= 0, subpatch counts up from 0, patch = subpatch / d.
bad=$(awk -F, -v d=4 '
    NR == 1 { next }
    {
        if ($1 != NR - 2 || $2 != int($1 / d)) { print "row " NR ": index " $1 " patch " $2; exit }
        for (i = 10; i <= 12; i++)
            if ($i !~ /^[0-9]+(\.[0-9]*)?([eE][-+]?[0-9]+)?$/) { print "row " NR ": b = " $i; exit }
        if (NF != 12) { print "row " NR ": " NF " fields"; exit }
    }' "$CSV")
if [ -z "$bad" ] && [ "$rows" -gt 0 ]; then pass "CSV: indices in order, all b finite and >= 0"; else fail "CSV: $bad"; fi

run solve "$LRRFILE" --emission-scale 2 --repeat 1
mean2=$(value mean_b_r)
if [ "$rc" -eq 0 ] && awk -v a="$mean1" -v b="$mean2" \
    'BEGIN { r = b - 2 * a; if (r < 0) r = -r; exit !(a > 0 && r <= 1e-5 * b) }'; then
    pass "solve is linear in the emission: $mean2 = 2 x $mean1"
else
    fail "emission scale 2: mean_b_r '$mean2' vs 2 x '$mean1' (exit $rc)"
fi

run solve "$LRRFILE" --emission-scale 0 --repeat 1
if [ "$rc" -eq 0 ] && [ "$(value max_b)" = 0 ]; then
    pass "no emission, no light: max_b = 0"
else
    fail "emission scale 0: max_b '$(value max_b)' (exit $rc)"
fi

run solve "$LRRFILE" --csv "$T/no-such-dir/b.csv" --repeat 1
if [ "$rc" -eq 1 ] && grep -q 'no-such-dir/b.csv' "$T/err"; then
    pass "unwritable CSV: exit 1 naming it"
else
    fail "unwritable CSV: exit $rc, stderr: $(cat "$T/err")"
fi

# Every path gives the same answer; the path and the SIMD kernel are reported.
for p in full sparse incremental auto; do
    run solve "$LRRFILE" --path "$p" --repeat 2
    m=$(value mean_b_r)
    if [ "$rc" -eq 0 ] && [ -n "$(value kernel)" ] && awk -v a="$mean1" -v b="$m" \
        'BEGIN { r = b - a; if (r < 0) r = -r; exit !(a > 0 && r <= 1e-5 * a) }'; then
        pass "solve --path $p: took $(value path), kernel $(value kernel), mean_b_r = $m"
    else
        fail "solve --path $p: mean_b_r '$m' vs '$mean1' (exit $rc)"
        show_err
    fi
done
run solve "$LRRFILE" --path sideways
expect_rc 2 "solve --path sideways is a usage error"

# The OpenCL backend gives the CPU's answer; skipped (with a PASS line saying so) where the
# library has no OpenCL or the machine no OpenCL platform.
run solve "$LRRFILE" --backend opencl --repeat 2
m=$(value mean_b_r)
if [ "$rc" -ne 0 ] && grep -Eq 'not built into|no OpenCL platform' "$T/err"; then
    pass "solve --backend opencl: skipped, no OpenCL here ($(head -n 1 "$T/err"))"
elif [ "$rc" -eq 0 ] && [ "$(value backend)" = opencl ] && awk -v a="$mean1" -v b="$m" \
    'BEGIN { r = b - a; if (r < 0) r = -r; exit !(a > 0 && r <= 1e-5 * a) }'; then
    pass "solve --backend opencl: kernel $(value kernel), mean_b_r = $m vs $mean1"
else
    fail "solve --backend opencl: mean_b_r '$m' vs '$mean1' (exit $rc)"
    show_err
fi
(LRR_OPENCL_DEVICE=no-such-device; export LRR_OPENCL_DEVICE
    lrr_exec solve "$LRRFILE" --backend opencl --repeat 1 >"$T/out" 2>"$T/err")
rc=$?
if [ "$rc" -eq 1 ] && grep -Eq 'not built into|no OpenCL platform' "$T/err"; then
    pass "LRR_OPENCL_DEVICE=no-such-device: skipped, no OpenCL here"
elif [ "$rc" -eq 1 ] && grep -q 'LRR_OPENCL_DEVICE' "$T/err"; then
    pass "LRR_OPENCL_DEVICE=no-such-device: exit 1 naming the variable"
else
    fail "LRR_OPENCL_DEVICE=no-such-device: exit $rc, stderr: $(cat "$T/err")"
fi
# No OpenCL platform at all (the ICD loader pointed at an empty vendor directory): the
# documented error, exit 1, never a crash.
mkdir -p "$T/no-icd"
(OCL_ICD_VENDORS="$T/no-icd"; export OCL_ICD_VENDORS
    lrr_exec solve "$LRRFILE" --backend opencl --repeat 1 >"$T/out" 2>"$T/err")
rc=$?
if [ "$rc" -eq 1 ] && grep -q 'not built into' "$T/err"; then
    pass "no OpenCL platform: skipped, OpenCL not built in"
elif [ "$rc" -eq 1 ] && grep -q 'no OpenCL platform found' "$T/err"; then
    pass "no OpenCL platform: exit 1, $(head -n 1 "$T/err")"
else
    fail "no OpenCL platform: exit $rc, stderr: $(cat "$T/err")"
fi
run solve "$LRRFILE" --backend gpu
expect_rc 2 "solve --backend gpu is a usage error"
# Hemicube integration on the device builds the same operator (same skip rule as above).
CLFILE="$T/small-cl.lrr"
run preprocess cornell -o "$CLFILE" --patches 30 --levels 1 --hemicube 32 --threads 2 \
    --backend opencl
if [ "$rc" -ne 0 ] && grep -Eq 'not built into|no OpenCL platform' "$T/err"; then
    pass "preprocess --backend opencl: skipped, no OpenCL here ($(head -n 1 "$T/err"))"
elif [ "$rc" -eq 0 ] && [ "$(value backend)" = opencl ]; then
    run solve "$CLFILE" --repeat 1
    m=$(value mean_b_r)
    if [ "$rc" -eq 0 ] && awk -v a="$mean1" -v b="$m" \
        'BEGIN { r = b - a; if (r < 0) r = -r; exit !(a > 0 && r <= 1e-5 * a) }'; then
        pass "preprocess --backend opencl: mean_b_r = $m vs $mean1"
    else
        fail "preprocess --backend opencl, then solve: mean_b_r '$m' vs '$mean1' (exit $rc)"
        show_err
    fi
else
    fail "preprocess --backend opencl (exit $rc, backend '$(value backend)')"
    show_err
fi
run preprocess cornell -o "$CLFILE" --backend gpu
expect_rc 2 "preprocess --backend gpu is a usage error"
(LRR_SIMD=c; export LRR_SIMD; lrr_exec solve "$LRRFILE" --repeat 1 >"$T/out" 2>"$T/err")
rc=$?
if [ "$rc" -eq 0 ] && [ "$(value kernel)" = c ]; then pass "LRR_SIMD=c forces the portable kernel"; else fail "LRR_SIMD=c: exit $rc, kernel '$(value kernel)'"; fi

# 16-bit storage: half the bytes of F̄ on disk, the same radiosity to the rounding of F̄.
for st in f16 bf16; do
    run preprocess cornell --patches 24 --levels 1 --hemicube 32 --storage "$st" -o "$T/$st.lrr"
    if [ "$rc" -eq 0 ] && [ "$(value storage)" = "$st" ] &&
        [ "$(wc -c <"$T/$st.lrr")" -lt "$(wc -c <"$LRRFILE")" ]; then
        run solve "$T/$st.lrr" --repeat 1
        m=$(value mean_b_r)
        if [ "$rc" -eq 0 ] && [ "$(value storage)" = "$st" ] && awk -v a="$mean1" -v b="$m" \
            'BEGIN { r = b - a; if (r < 0) r = -r; exit !(a > 0 && r <= 1e-3 * a) }'; then
            pass "--storage $st: smaller file, mean_b_r = $m vs $mean1"
        else
            fail "--storage $st solve: mean_b_r '$m' vs '$mean1' (exit $rc)"
        fi
    else
        fail "preprocess --storage $st (exit $rc)"
        show_err
    fi
done
# Without the random rotation the seed makes no difference to the operator.
run preprocess cornell --patches 24 --levels 1 --hemicube 32 --no-rotation --seed 1 -o "$T/nr1.lrr"
rc1=$rc
run preprocess cornell --patches 24 --levels 1 --hemicube 32 --no-rotation --seed 2 -o "$T/nr2.lrr"
run solve "$T/nr1.lrr" --csv "$T/nr1.csv" --repeat 1
run solve "$T/nr2.lrr" --csv "$T/nr2.csv" --repeat 1
if [ "$rc1" -eq 0 ] && [ "$rc" -eq 0 ] && cmp -s "$T/nr1.csv" "$T/nr2.csv"; then
    pass "--no-rotation: seeds 1 and 2 give the same radiosity"
else
    fail "--no-rotation: seeds differ (exit $rc1/$rc)"
fi
run preprocess cornell --storage f8 -o "$T/f8.lrr"
expect_rc 2 "preprocess --storage f8 is a usage error"
# --formfactor: the method used is printed (auto: raster on the 36-triangle box); the
# ray-cast operator solves to nearly the same radiosity (the same pixels); a bad name is a
# usage error.
for ff in auto:raster raster:raster raycast:raycast; do
    run preprocess cornell --patches 24 --levels 1 --hemicube 32 --formfactor "${ff%%:*}" \
        --receiver centre -o "$T/ff-${ff%%:*}.lrr"
    if [ "$rc" -eq 0 ] && [ "$(value formfactor)" = "${ff#*:}" ]; then
        pass "preprocess --formfactor ${ff%%:*} prints formfactor: ${ff#*:}"
    else
        fail "preprocess --formfactor ${ff%%:*} (exit $rc, formfactor: $(value formfactor))"
        show_err
    fi
done
run solve "$T/ff-raster.lrr" --csv "$T/ff-raster.csv" --repeat 1
run solve "$T/ff-raycast.lrr" --csv "$T/ff-raycast.csv" --repeat 1
run compare "$T/ff-raycast.csv" "$T/ff-raster.csv"
l2=$(value rel_l2)
if [ "$rc" -eq 0 ] && awk -v e="$l2" 'BEGIN { exit !(e > 0 && e < 1e-3) }'; then
    pass "raycast and raster operators give the same radiosity (rel_l2 $l2)"
else
    fail "compare raster/raycast (exit $rc, rel_l2 '$l2')"
    show_err
fi
run preprocess cornell --formfactor zbuffer -o "$T/ff.lrr"
expect_rc 2 "preprocess --formfactor zbuffer is a usage error"

# ---------------------------------------------------------------- render
PNG="$T/b.png"
run render "$LRRFILE" -o "$PNG" --width 64 --height 48
sig=$(od -An -tx1 -N8 "$PNG" 2>/dev/null | tr -d ' \n')
if [ "$rc" -eq 0 ] && [ "$sig" = 89504e470d0a1a0a ]; then
    pass "render writes a PNG ($(wc -c <"$PNG" | tr -d ' ') bytes)"
else
    fail "render (exit $rc), signature '$sig'"
    show_err
fi

# cameras: --eye/--target (and --up, --fov) give a pinhole camera; each bad value is a usage
# error naming its option
run render "$LRRFILE" -o "$T/eye.png" --width 32 --height 24 --eye 278,273,-800 \
    --target 278,273,0 --up 0,1,0 --fov 45
sig=$(od -An -tx1 -N8 "$T/eye.png" 2>/dev/null | tr -d ' \n')
if [ "$rc" -eq 0 ] && [ "$sig" = 89504e470d0a1a0a ]; then
    pass "render --eye --target --up --fov writes a PNG"
else
    fail "render --eye --target (exit $rc), signature '$sig'"
    show_err
fi
# bad_camera OPTION DESCRIPTION ARGS...: exit 2, a message naming OPTION, no picture
bad_camera() {
    opt=$1 what=$2
    shift 2
    rm -f "$T/bad.png"
    run render "$LRRFILE" -o "$T/bad.png" --width 8 --height 8 "$@"
    if [ "$rc" -eq 2 ] && grep -q -- "$opt" "$T/err" && [ ! -e "$T/bad.png" ]; then
        pass "render: $what is a usage error naming $opt"
    else
        fail "render: $what: exit $rc, expected 2 and a message naming $opt"
        show_err
    fi
}
bad_camera --target "eye = target" --eye 1,2,3 --target 1,2,3
bad_camera --up "up parallel to the view" --eye 0,0,0 --target 0,5,0
bad_camera --up "up parallel (explicit)" --eye 0,0,0 --target 1,0,0 --up -2,0,0
bad_camera --up "a zero up" --eye 0,0,0 --target 1,0,0 --up 0,0,0
bad_camera --eye "a non-finite eye" --eye 0,nan,0 --target 1,0,0
bad_camera --target "an infinite target" --eye 0,0,0 --target inf,0,0
bad_camera --eye "two coordinates" --eye 0,0 --target 1,0,0
bad_camera --eye "four coordinates" --eye 0,0,0,0 --target 1,0,0
bad_camera --up "a non-number up" --eye 0,0,0 --target 1,0,0 --up a,b,c
bad_camera --fov "fov 0" --fov 0
bad_camera --fov "fov 180" --fov 180
bad_camera --fov "fov -10" --fov -10
bad_camera --eye "--eye without --target" --eye 0,0,0
bad_camera --eye "--target without --eye" --target 0,0,0
bad_camera --eye "--eye with --camera" --eye 0,0,0 --target 1,0,0 --camera fit

# formats: .exr (any case) is linear OpenEXR, --format wins over the extension, an unknown
# extension without --format is refused
run render "$LRRFILE" -o "$T/lin.EXR" --width 32 --height 16
sig=$(od -An -tx1 -N4 "$T/lin.EXR" 2>/dev/null | tr -d ' \n')
if [ "$rc" -eq 0 ] && [ "$sig" = 762f3101 ]; then
    pass "render -o X.EXR writes OpenEXR ($(wc -c <"$T/lin.EXR" | tr -d ' ') bytes)"
else
    fail "render -o X.EXR (exit $rc), signature '$sig'"
    show_err
fi
run render "$LRRFILE" -o "$T/lin.png" --format exr --width 32 --height 16
sig=$(od -An -tx1 -N4 "$T/lin.png" 2>/dev/null | tr -d ' \n')
if [ "$rc" -eq 0 ] && [ "$sig" = 762f3101 ]; then
    pass "render --format exr wins over the .png extension"
else
    fail "render --format exr -o X.png (exit $rc), signature '$sig'"
fi
rm -f "$T/pic.jpg"
run render "$LRRFILE" -o "$T/pic.jpg" --width 8 --height 8
if [ "$rc" -eq 2 ] && grep -q 'unknown picture format' "$T/err" && grep -q -- '--format' "$T/err" &&
    [ ! -e "$T/pic.jpg" ]; then
    pass "render -o X.jpg is refused (exit 2, suggests --format)"
else
    fail "render -o X.jpg: exit $rc, expected 2 and a message"
    show_err
fi
run render "$LRRFILE" -o "$T/pic.jpg" --format tiff
expect_rc 2 "render --format tiff is a usage error"
# --emission-scale S scales the solve, which is linear and exact for S = 2 (a power of two):
# S = 2 at exposure 1 is the picture of S = 1 at exposure 2, bit for bit, and not that of
# S = 1 at exposure 1. (render listed the option but refused it as "unknown option '2'".)
run render "$LRRFILE" -o "$T/s2.png" --width 32 --height 24 --emission-scale 2 --exposure 1
rc1=$rc
run render "$LRRFILE" -o "$T/x2.png" --width 32 --height 24 --emission-scale 1 --exposure 2
rc2=$rc
run render "$LRRFILE" -o "$T/s1.png" --width 32 --height 24 --exposure 1
if [ "$rc1$rc2$rc" = 000 ] && cmp -s "$T/s2.png" "$T/x2.png" && ! cmp -s "$T/s2.png" "$T/s1.png"; then
    pass "render --emission-scale 2 = --exposure 2, bit for bit"
else
    fail "render --emission-scale 2 vs --exposure 2 (exit $rc1 $rc2 $rc)"; show_err
fi

# ---------------------------------------------------------------- export
run export "$LRRFILE" -o "$T/lit.glb"
sig=$(od -An -c -N4 "$T/lit.glb" 2>/dev/null | tr -d ' \n')
if [ "$rc" -eq 0 ] && [ "$sig" = glTF ] && [ "$(value vertices)" -gt 0 ] &&
    [ "$(value triangles)" -gt 0 ] && [ "$(value materials)" -gt 0 ] &&
    [ "$(value output)" = "$T/lit.glb" ]; then
    pass "export writes a .glb ($(value vertices) vertices, $(value triangles) triangles)"
else
    fail "export -o X.glb (exit $rc), signature '$sig'"
    show_err
fi
tris=$(value triangles)
glb_vertices=$(value vertices)
glb_materials=$(value materials)
run export "$LRRFILE" -o "$T/lit.ply" --subpatches --exposure auto
if [ "$rc" -eq 0 ] && [ "$(head -c 4 "$T/lit.ply")" = ply ] &&
    grep -aq "^element face $(value triangles)\$" "$T/lit.ply" && [ "$(value triangles)" -gt "$tris" ]; then
    pass "export --subpatches -o X.ply writes the subpatch mesh as PLY"
else
    fail "export --subpatches -o X.ply (exit $rc)"
    show_err
fi
# the Khronos validator, where it is installed (npm gltf-validator); skipped otherwise
VALIDATOR_JS=""
if command -v node >/dev/null 2>&1 && command -v npm >/dev/null 2>&1; then
    npm_root=$(npm root -g 2>/dev/null)
    [ -f "$npm_root/gltf-validator/package.json" ] && VALIDATOR_JS="$npm_root/gltf-validator"
fi
if [ -n "$VALIDATOR_JS" ]; then
    errors=$(node -e "require('$VALIDATOR_JS').validateBytes(new Uint8Array(require('fs')
        .readFileSync(process.argv[1]))).then(r => console.log(r.issues.numErrors))" "$T/lit.glb")
    if [ "$errors" = 0 ]; then pass "gltf-validator: 0 errors"; else fail "gltf-validator: '$errors' errors"; fi
else
    echo "SKIP: gltf-validator (npm) is not installed"
fi
# Blender's own glTF importer, where Blender is installed (Debian blender, python3-numpy)
if command -v blender >/dev/null 2>&1; then
    blender -b --python "${LRR_SRCDIR:-.}/tests/blender_import.py" -- "$T/lit.glb" > "$T/blender" 2>&1
    line=$(grep '^BLENDER_IMPORT' "$T/blender")
    if [ "$line" = "BLENDER_IMPORT meshes 1 vertices $glb_vertices triangles $tris materials $glb_materials" ] &&
        grep -q "^BLENDER_COLOR Col" "$T/blender"; then
        pass "Blender imports the .glb: $line, with its vertex colours"
    else
        fail "Blender import: '$line'"; grep -E 'Error|BLENDER' "$T/blender" | head -n 5
    fi
else
    echo "SKIP: blender is not installed"
fi
run export "$LRRFILE" -o "$T/lamp.glb" --light 'point pos=278,400,279 rgb=30000' \
    --no-scene-emission --exposure auto
if [ "$rc" -eq 0 ] && [ "$(value triangles)" = "$tris" ] &&
    awk -v x="$(value exposure)" 'BEGIN { exit !(x > 0) }'; then
    pass "export --light: the lit mesh of a moving light"
else
    fail "export --light (exit $rc)"; show_err
fi
run export "$LRRFILE" -o "$T/lamp.glb" --no-scene-emission
expect_rc 2 "export --no-scene-emission without --light or --probe is rejected"
run export "$LRRFILE" -o "$T/lit.obj"
expect_rc 2 "export -o X.obj without --format is a usage error"
run export "$LRRFILE" -o "$T/lit.glb" --format fbx
expect_rc 2 "export --format fbx is a usage error"
run export "$LRRFILE" -o "$T/lit.glb" --exposure 0
expect_rc 2 "export --exposure 0 is a usage error"
run export "$LRRFILE"
expect_rc 2 "export without -o is a usage error"

# One parser reads the options of solve, render, export and animate (cli_parse_command): an
# unknown option, a missing value and a bad number get the same message in each, exit 2.
# usage_error CMD WANT ARGS...: lrr CMD ARGS exits 2 with "lrr CMD: WANT" on stderr
usage_error() {
    cmd=$1 want=$2
    shift 2
    run "$cmd" "$LRRFILE" "$@"
    if [ "$rc" -eq 2 ] && grep -qF -- "lrr $cmd: $want" "$T/err" && [ ! -s "$T/out" ]; then
        pass "$cmd $*: exit 2, $want"
    else
        fail "$cmd $*: exit $rc, expected 2 and 'lrr $cmd: $want': $(cat "$T/err")"
    fi
}
for o in "solve --repeat" "render --width" "export --format" "animate --fov"; do
    cmd=${o% *} o=${o#* }
    usage_error $cmd "unknown option '--bogus'" --bogus
    usage_error $cmd "unknown option '-x'" -x
    usage_error $cmd "$o: a value is required" $o
done
usage_error animate "unknown option '--emission-scale'" --emission-scale 2 # no emission here
set --
while [ $# -lt 34 ]; do set -- "$@" --light 'sun dir=0,1,0 rgb=1'; done
for o in "solve --repeat=1" "render -o$T/u.png" "export -o$T/u.glb"; do
    cmd=${o%% *} o=${o#* }
    usage_error $cmd "--emission-scale: a value is required" $o --emission-scale
    usage_error $cmd "--emission-scale: 'abc' is not a number" $o --emission-scale abc
    usage_error $cmd "--emission-scale: '-1' is out of range" $o --emission-scale=-1
    usage_error $cmd "--sources, --probe-method and --probe-scale need --probe" $o --probe-scale 2
    usage_error $cmd "--light: at most 16 lights" $o "$@" # 17 of them
done
for cmd in render animate; do
    usage_error $cmd "--width: '0' is out of range (1..16384)" --width 0
    usage_error $cmd "--fov: '180' is out of range (it must be less than 180)" --fov 180
    usage_error $cmd "--camera: 'nope' is not one of cornell, fit, auto" --camera nope
done
usage_error solve "--repeat: '1x' is not an integer" --repeat 1x
usage_error solve "--csv: the file name is empty" --csv ''
usage_error export "--exposure: '0' is out of range (it must be greater than 0)" -o "$T/u.glb" \
    --exposure 0
usage_error export "--format: 'obj' is not one of gltf, ply" -o "$T/u.glb" --format obj
usage_error animate "--format: 'tiff' is not one of png, exr" --format tiff
# a required option left out: the same message and hint in each command
usage_error render "-o OUT.png (or OUT.exr) is required" --width 8
usage_error export "-o OUT.glb (or OUT.ply) is required" --subpatches
usage_error animate "--lights SCRIPT is required" -o "$T/u"
usage_error animate "-o DIR is required" --lights "$T/u.txt"
if grep -qF "Try 'lrr animate --help'." "$T/err"; then
    pass "animate: a required option left out suggests --help, as render's and export's do"
else
    fail "animate: no --help hint in: $(cat "$T/err")"
fi

# ---------------------------------------------------------------- damaged input
size=$(wc -c <"$LRRFILE" | tr -d ' ')
head -c $((size / 2)) "$LRRFILE" >"$T/truncated.lrr"
run solve "$T/truncated.lrr" --repeat 1
if [ "$rc" -eq 1 ] && grep -Eqi 'corrupt|truncated' "$T/err"; then
    pass "truncated .lrr: exit 1, $(head -n 1 "$T/err")"
else
    fail "truncated .lrr: exit $rc, stderr: $(cat "$T/err")"
fi

run solve "$T/no-such.lrr"
if [ "$rc" -eq 1 ] && grep -q 'no-such.lrr' "$T/err"; then
    pass "missing .lrr: exit 1 naming it"
else
    fail "missing .lrr: exit $rc, stderr: $(cat "$T/err")"
fi

# ---------------------------------------------------------------- reference
# Every method on the same tiny scene: the CSV has the columns of `lrr solve --csv`, n rows.
SMALL="cornell --patches 24 --levels 1 --hemicube 32"
for m in jacobi gauss-seidel southwell direct; do
    # shellcheck disable=SC2086 # SMALL is a list of arguments
    run reference $SMALL --method "$m" --tol 1e-9 --csv "$T/ref-$m.csv"
    rn=$(value n)
    [ -f "$T/ref-$m.csv" ] || : >"$T/ref-$m.csv"
    rrows=$(($(wc -l <"$T/ref-$m.csv") - 1))
    if [ "$rc" -eq 0 ] && [ "$(value method)" = "$m" ] && [ -n "$rn" ] && [ "$rn" -gt 0 ] &&
        [ "$(head -n 1 "$T/ref-$m.csv")" = "$header" ] && [ "$rrows" = "$rn" ] &&
        [ -n "$(value residual)" ] && [ -n "$(value mean_b_r)" ]; then
        pass "reference --method $m: n = $rn, $(value iterations) iterations, residual $(value residual), CSV of n rows"
    else
        fail "reference --method $m (exit $rc): n '$rn', method '$(value method)', CSV rows $rrows, header '$(head -n 1 "$T/ref-$m.csv")'"
        show_err
    fi
done
leftover=""
for f in "$T"/*tmp*; do [ -e "$f" ] && leftover="$leftover $f"; done
if [ -n "$leftover" ]; then fail "reference left temporary files:$leftover"; else pass "reference left no temporary file"; fi

# shellcheck disable=SC2086
run reference $SMALL --method jacobi --max-iterations 2 --csv "$T/ref-unconverged.csv"
if [ "$rc" -eq 3 ] && grep -q 'did not converge' "$T/err" && grep -q 'residual' "$T/err" &&
    grep -q 'after 2 iterations' "$T/err" && [ "$(value iterations)" = 2 ] &&
    [ "$(($(wc -l <"$T/ref-unconverged.csv") - 1))" = "$(value n)" ]; then
    pass "reference not converged: exit 3, warning, CSV still written"
else
    fail "reference --max-iterations 2: exit $rc, stderr: $(cat "$T/err")"
fi

# n = 552 (cornell, 138 patches x 4): F alone takes n^2 x 4 bytes = 1.2 MB > 1 MiB.
run reference cornell --patches 150 --levels 1 --hemicube 32 --method jacobi --memory-budget 1
if [ "$rc" -eq 1 ] && grep -q 'budget' "$T/err" && grep -q 'n = 552' "$T/err"; then
    pass "--memory-budget 1: exit 1, $(head -n 1 "$T/err")"
else
    fail "--memory-budget 1: exit $rc, stderr: $(cat "$T/err")"
fi
run reference cornell --patches 150 --levels 1 --hemicube 32 --method direct --memory-budget 3
if [ "$rc" -eq 1 ] && grep -q 'budget' "$T/err" && grep -q 'LU' "$T/err"; then
    pass "--memory-budget 3 with direct (F fits, its LU does not): exit 1"
else
    fail "--memory-budget 3 --method direct: exit $rc, stderr: $(cat "$T/err")"
fi

# ---------------------------------------------------------------- compare
# num_le VALUE LIMIT: VALUE is a plain number (not inf or nan) <= LIMIT.
num_le() {
    awk -v v="$1" -v l="$2" 'BEGIN { exit !(v ~ /^[-+]?[0-9.]+([eE][-+]?[0-9]+)?$/ && v + 0 <= l + 0) }'
}
# num_near VALUE WANT TOL: VALUE is a plain number and |VALUE - WANT| <= TOL.
num_near() {
    awk -v v="$1" -v w="$2" -v t="$3" 'BEGIN { d = v - w; if (d < 0) d = -d
        exit !(v ~ /^[-+]?[0-9.]+([eE][-+]?[0-9]+)?$/ && d <= t + 0) }'
}

REF="$T/ref-direct.csv"
run compare "$REF" "$REF"
if [ "$rc" -eq 0 ] && [ "$(value rel_l2)" = 0 ] && [ "$(value max_rel)" = 0 ] &&
    [ "$(value mean_abs)" = 0 ] && [ "$(value n)" = "$(($(wc -l <"$REF") - 1))" ]; then
    pass "compare X X: rel_l2 0, max_rel 0, mean_abs 0"
else
    fail "compare X X (exit $rc): rel_l2 '$(value rel_l2)', max_rel '$(value max_rel)', mean_abs '$(value mean_abs)'"
    show_err
fi

# Every radiosity x 1.01: relative errors of exactly 0.01; mean_abs recomputed with awk.
awk -F, -v OFS=, 'NR > 1 { for (i = 10; i <= 12; i++) $i = sprintf("%.9g", $i * 1.01) } { print }' \
    "$REF" >"$T/scaled.csv"
want_mean_abs=$(awk -F, '
    NR == FNR { if (FNR > 1) { a[FNR] = $10; b[FNR] = $11; c[FNR] = $12 } next }
    FNR > 1 {
        d = 0
        x = a[FNR] - $10; d += x < 0 ? -x : x
        x = b[FNR] - $11; d += x < 0 ? -x : x
        x = c[FNR] - $12; d += x < 0 ? -x : x
        s += $3 * d; area += $3
    }
    END { printf "%.12g", s / (3 * area) }' "$T/scaled.csv" "$REF")
run compare "$T/scaled.csv" "$REF"
got_mean_abs=$(value mean_abs)
if [ "$rc" -eq 0 ] && num_near "$(value rel_l2)" 0.01 1e-4 && num_near "$(value max_rel)" 0.01 1e-4 &&
    num_near "$(value rel_l2_g)" 0.01 1e-4 && num_near "$(value max_rel_b)" 0.01 1e-4 &&
    awk -v g="$got_mean_abs" -v w="$want_mean_abs" \
        'BEGIN { d = g - w; if (d < 0) d = -d; exit !(g != "" && w > 0 && d <= 1e-6 * w) }'; then
    pass "compare 1.01 B vs B: rel_l2 $(value rel_l2), max_rel $(value max_rel), mean_abs $got_mean_abs (awk: $want_mean_abs)"
else
    fail "compare 1.01 B vs B (exit $rc): rel_l2 '$(value rel_l2)', max_rel '$(value max_rel)', mean_abs '$got_mean_abs' (awk: '$want_mean_abs')"
    show_err
fi

# The four methods solve the same system: they agree far below the low-rank error.
worst=0
bad_pairs=""
pairs=0
for pair in jacobi/gauss-seidel jacobi/southwell jacobi/direct gauss-seidel/southwell \
    gauss-seidel/direct southwell/direct; do
    run compare "$T/ref-${pair%/*}.csv" "$T/ref-${pair#*/}.csv"
    r=$(value rel_l2)
    pairs=$((pairs + 1))
    if [ "$rc" -ne 0 ] || ! num_le "$r" 1e-5; then
        bad_pairs="$bad_pairs $pair=${r:-exit $rc}"
    elif ! num_le "$r" "$worst"; then
        worst=$r
    fi
done
if [ -z "$bad_pairs" ]; then
    pass "the four methods agree: rel_l2 <= $worst for all $pairs pairs"
else
    fail "methods disagree (rel_l2 > 1e-5):$bad_pairs"
fi

# With d = 1 the low-rank model is exact: `lrr solve` matches the direct reference.
run preprocess cornell --patches 24 --levels 0 --hemicube 32 -o "$T/d1.lrr"
if [ "$rc" -eq 0 ] && ! grep -q 'warning' "$T/err"; then
    pass "preprocess of the Cornell box: no condition warning"
else
    fail "preprocess d = 1 (exit $rc), stderr: $(cat "$T/err")"
fi
run solve "$T/d1.lrr" --csv "$T/d1-solve.csv" --repeat 1
run reference cornell --patches 24 --levels 0 --hemicube 32 --method direct --csv "$T/d1-ref.csv"
run compare "$T/d1-solve.csv" "$T/d1-ref.csv"
if [ "$rc" -eq 0 ] && num_le "$(value rel_l2)" 1e-5; then
    pass "d = 1: lrr solve vs direct reference, rel_l2 $(value rel_l2), max_rel $(value max_rel)"
else
    fail "d = 1: compare solve vs reference (exit $rc): rel_l2 '$(value rel_l2)'"
    show_err
fi

# The path-traced reference writes a CSV that compares against Gauss–Seidel on the same
# subdivision (they differ by the hemicube's centre-point F and the noise: docs/METHOD.md
# "Path-traced reference").
run reference cornell --patches 150 --levels 0 --hemicube 128 --method gauss-seidel --csv "$T/pt-gs.csv"
run reference cornell --patches 150 --levels 0 --method path-trace --samples 256 --seed 3 --csv "$T/pt.csv"
ptrc=$rc
ptse=$(value rel_std_error)
run compare "$T/pt.csv" "$T/pt-gs.csv"
if [ "$ptrc" -eq 0 ] && [ "$rc" -eq 0 ] && num_le "$(value rel_l2)" 0.1; then
    pass "path-trace vs gauss-seidel: rel_l2 $(value rel_l2), rel_std_error $ptse"
else
    fail "path-trace vs gauss-seidel (exit $ptrc, compare $rc): rel_l2 '$(value rel_l2)'"
    show_err
fi

# Damaged or mismatched CSVs: exit 1 and a message naming the file.
size=$(wc -c <"$REF" | tr -d ' ')
head -c $((size / 2)) "$REF" >"$T/half.csv"
run compare "$T/half.csv" "$REF"
if [ "$rc" -eq 1 ] && grep -q 'half.csv' "$T/err"; then
    pass "truncated CSV: exit 1, $(head -n 1 "$T/err")"
else
    fail "truncated CSV: exit $rc, stderr: $(cat "$T/err")"
fi
head -n 20 "$REF" >"$T/short.csv"
run compare "$REF" "$T/short.csv"
if [ "$rc" -eq 1 ] && grep -q 'short.csv' "$T/err" && grep -q 'rows' "$T/err"; then
    pass "CSV cut at a line end: exit 1, rows counted"
else
    fail "short CSV: exit $rc, stderr: $(cat "$T/err")"
fi
sed '1s/b_g/B_G/' "$REF" >"$T/header.csv"
run compare "$T/header.csv" "$REF"
if [ "$rc" -eq 1 ] && grep -q "header.csv' line 1" "$T/err"; then
    pass "CSV header mismatch: exit 1 naming the file"
else
    fail "CSV header mismatch: exit $rc, stderr: $(cat "$T/err")"
fi
awk -F, -v OFS=, 'NR == 5 { $11 = "nan" } { print }' "$REF" >"$T/nan.csv"
run compare "$REF" "$T/nan.csv"
if [ "$rc" -eq 1 ] && grep -q "nan.csv' line 5" "$T/err"; then
    pass "NaN in a CSV: exit 1 naming file and line"
else
    fail "NaN in a CSV: exit $rc, stderr: $(cat "$T/err")"
fi
awk -F, -v OFS=, 'NR == 7 { $4 = "12x" } { print }' "$REF" >"$T/alpha.csv"
run compare "$T/alpha.csv" "$REF"
if [ "$rc" -eq 1 ] && grep -q "alpha.csv' line 7" "$T/err"; then
    pass "non-numeric CSV field: exit 1 naming file and line"
else
    fail "non-numeric CSV field: exit $rc, stderr: $(cat "$T/err")"
fi
run compare "$T/d1-ref.csv" "$REF"
if [ "$rc" -eq 1 ] && grep -q 'different subdivisions' "$T/err"; then
    pass "CSVs of different subdivisions: exit 1"
else
    fail "different subdivisions: exit $rc, stderr: $(cat "$T/err")"
fi
run compare "$REF" "$T/no-such.csv"
if [ "$rc" -eq 1 ] && grep -q 'no-such.csv' "$T/err"; then
    pass "missing CSV: exit 1 naming it"
else
    fail "missing CSV: exit $rc, stderr: $(cat "$T/err")"
fi

# ---------------------------------------------------------------- condition warning
# A closed cube of reflectance 0.99999: cond(I - R F) ~ 1e5, too much for a float M_c.
printf '%s\n' 'newmtl white' 'Kd 0.99999 0.99999 0.99999' 'newmtl light' \
    'Kd 0.99999 0.99999 0.99999' 'Ke 1 1 1' >"$T/cube.mtl"
{
    echo 'mtllib cube.mtl'
    for v in '0 0 0' '1 0 0' '1 1 0' '0 1 0' '0 0 1' '1 0 1' '1 1 1' '0 1 1'; do echo "v $v"; done
    echo 'usemtl white'
    for f in '1 2 3' '1 3 4' '1 6 2' '1 5 6' '4 3 7' '4 7 8' '1 4 8' '1 8 5' '2 6 7' '2 7 3'; do
        echo "f $f"
    done
    echo 'usemtl light'
    echo 'f 5 7 6'
    echo 'f 5 8 7'
} >"$T/cube.obj"
run preprocess "$T/cube.obj" -o "$T/cube.lrr" --patches 12 --levels 1 --hemicube 32
if [ "$rc" -eq 0 ] && [ -s "$T/cube.lrr" ] && grep -q 'warning: condition estimate' "$T/err"; then
    pass "ill-conditioned scene: exit 0 with a warning (cond_r $(value cond_r))"
else
    fail "ill-conditioned scene: exit $rc, cond_r '$(value cond_r)', stderr: $(cat "$T/err")"
fi

# ---------------------------------------------------------------- light probes
PROBE=${LRR_DATA_DIR:-data}/probes/studio.hdr
if [ -r "$PROBE" ]; then
    help_mentions probe --method --sources --normals --lights --json --max-iterations
    run probe "$PROBE" --sources 8 --normals 256 --lights "$T/lights.csv"
    mean=$(value mean_error_pct)
    if [ "$rc" -eq 0 ] && awk -v x="$mean" 'BEGIN { exit !(x + 0 == x && x >= 0 && x < 1e30) }' &&
        [ "$(value sources)" = 8 ] && [ "$(value iterations)" = 3 ] &&
        [ "$(wc -l <"$T/lights.csv")" -eq 9 ] && head -n 1 "$T/lights.csv" | grep -qx 'x,y,z,r,g,b'; then
        pass "lrr probe median-cut: mean_error_pct $mean, 8 lights written"
    else
        fail "lrr probe median-cut: exit $rc, mean_error_pct '$mean'"; show_err
    fi
    run probe "$PROBE" --method sh9 --normals 256 --json
    json_ok=1
    [ "$rc" -eq 0 ] && [ "$(wc -l <"$T/out")" -eq 1 ] || json_ok=0
    for k in mean_error_pct max_error_pct sources iterations seconds; do
        grep -q "\"$k\": " "$T/out" || json_ok=0
    done
    if [ "$json_ok" -eq 1 ] && command -v python3 >/dev/null 2>&1; then
        python3 -c 'import json, math, sys
d = json.loads(open(sys.argv[1]).read())
assert math.isfinite(d["mean_error_pct"]) and d["sources"] == 9' "$T/out" 2>"$T/err" ||
            json_ok=0
    fi
    if [ "$json_ok" -eq 1 ]; then
        pass "lrr probe --method sh9 --json: one line, the keys present"
    else
        fail "lrr probe --json (exit $rc): $(cat "$T/out")"; show_err
    fi
    run probe "$PROBE" --method irradiance --sources 8 --normals 256 --max-iterations 20
    mean=$(sed -n 's/^mean_error_pct: //p' "$T/out")
    it=$(sed -n 's/^iterations: //p' "$T/out")
    if [ "$rc" = 0 ] && grep -q '^method: irradiance$' "$T/out" && [ -n "$it" ] &&
        [ "$it" -le 20 ] && awk -v e="$mean" 'BEGIN { exit !(e + 0 > 0 && e + 0 < 5) }'; then
        pass "lrr probe --method irradiance: mean_error_pct $mean after $it iterations"
    else
        fail "lrr probe --method irradiance: exit $rc: $(cat "$T/out")"; show_err
    fi
    run probe "$PROBE" --method sh9 --max-iterations 5
    expect_rc 2 "lrr probe --max-iterations without --method irradiance"
    run probe "$PROBE" --method nope
    expect_rc 2 "lrr probe --method nope"
    run probe "$T/missing.hdr"
    expect_rc 1 "lrr probe on a missing file"
else
    fail "probe $PROBE not found (LRR_DATA_DIR)"
fi

# ---------------------------------------------------------------- probe lighting
if [ -f "$PROBE" ]; then
    finite_means() {
        for k in mean_b_r mean_b_g mean_b_b; do
            v=$(value "$k")
            awk -v x="$v" 'BEGIN { exit !(x != "" && x + 0 == x + 0 && x + 0 > 0 && x + 0 < 1e30) }' || return 1
        done
    }
    run solve "$LRRFILE" --probe "$PROBE" --sources 4 --repeat 1
    if [ "$rc" -eq 0 ] && [ "$(value sources)" = 4 ] && [ "$(value probe)" = "$PROBE" ] &&
        [ -n "$(value direct_light_seconds)" ] && finite_means; then
        pass "solve --probe: mean_b_r $(value mean_b_r), direct light $(value direct_light_seconds) s"
    else
        fail "solve --probe (exit $rc): $(cat "$T/out")"; show_err
    fi
    run solve "$LRRFILE" --probe "$PROBE" --sources 4 --probe-method median-cut \
        --no-scene-emission --probe-scale 2 --repeat 1
    if [ "$rc" -eq 0 ] && finite_means; then
        pass "solve --probe median-cut, probe light only: mean_b_r $(value mean_b_r)"
    else
        fail "solve --probe --probe-method median-cut --no-scene-emission (exit $rc)"; show_err
    fi
    run solve "$LRRFILE" --sources 4
    expect_rc 2 "solve --sources without --probe"
    run solve "$LRRFILE" --probe "$PROBE" --probe-method nope
    expect_rc 2 "solve --probe-method nope"
    run render "$LRRFILE" -o "$T/probe.png" --probe "$PROBE" --sources 4 --width 64 --height 64
    if [ "$rc" -eq 0 ] && [ -s "$T/probe.png" ] &&
        [ "$(head -c 8 "$T/probe.png" | od -An -tx1 | tr -d ' \n')" = 89504e470d0a1a0a ]; then
        pass "render --probe writes a PNG"
    else
        fail "render --probe (exit $rc)"; show_err
    fi
fi

# ---------------------------------------------------------------- textures
# The shipped textured glTF (data/textured/SOURCE.md): one texture, its white texels × the
# default factor 1 clamped below 1, counted by lrr info and warned about by lrr preprocess;
# a missing texture is a runtime error naming the file and the material.
BOXTEX=${LRR_DATA_DIR:-data}/textured/BoxTextured.gltf
run info "$BOXTEX"
if [ "$rc" -eq 0 ] && [ "$(value triangles)" = 12 ] && [ "$(value textures)" = 1 ] &&
    [ "$(value clamped_texels)" -gt 0 ] && [ "$(value clamped_texels)" -lt $((211 * 211)) ]; then
    pass "info BoxTextured.gltf: textures 1, clamped_texels $(value clamped_texels)"
else
    fail "info $BOXTEX (exit $rc): textures '$(value textures)' clamped '$(value clamped_texels)'"
    show_err
fi
run preprocess "$BOXTEX" --patches 12 --levels 1 --hemicube 16 -o "$T/boxtex.lrr"
if [ "$rc" -eq 0 ] && grep -q "warning: [0-9]* texel(s) of reflectance textures" "$T/err"; then
    pass "preprocess BoxTextured.gltf: warns about the clamped texels"
else
    fail "preprocess $BOXTEX (exit $rc)"; show_err
fi
sed 's/CesiumLogoFlat.png/no-such-texture.png/' "$BOXTEX" > "$T/BoxTextured.gltf"
cp "${LRR_DATA_DIR:-data}/textured/BoxTextured0.bin" "$T/"
run info "$T/BoxTextured.gltf"
if [ "$rc" -eq 1 ] && grep -q "material 'Texture'" "$T/err" && grep -q "no-such-texture.png" "$T/err"; then
    pass "info with a missing texture: exit 1, $(head -n 1 "$T/err")"
else
    fail "info with a missing texture (exit $rc)"; show_err
fi

# ---------------------------------------------------------------- lrr check
# obj_used_positions FILE.obj: the distinct positions (parsed as numbers) its faces use
obj_used_positions() {
    awk '$1 == "v" { n++; x[n] = sprintf("%.9g %.9g %.9g", $2, $3, $4) }
         $1 == "f" { for (i = 2; i <= NF; i++) { split($i, p, "/");
                     u[x[p[1] < 0 ? n + 1 + p[1] : p[1]]] = 1 } }
         END { c = 0; for (k in u) c++; print c }' "$1"
}
# obj_runs FILE.obj: its runs of faces with the same object (or group) and material,
# faces with a repeated vertex index (degenerate) left out: one usemtl each in the repair
obj_runs() {
    awk '$1 == "o" || $1 == "g" { g = $2 } $1 == "usemtl" { m = $2 }
         $1 == "f" { for (i = 2; i <= NF; i++) for (j = 2; j < i; j++) if ($i == $j) next
                     if (g SUBSEP m != last) c++; last = g SUBSEP m }
         END { print c + 0 }' "$1"
}
# obj_names KEY FILE: the sorted distinct names after KEY (usemtl, newmtl, g)
obj_names() { awk -v k="$1" '$1 == k { print $2 }' "$2" | sort -u | tr '\n' ' '; }
# Under valgrind the scene check refuses to run: valgrind computes every floating-point
# operation rounded to nearest, and CGAL's exact predicates need directed rounding
# (lib/scene/check.cpp). The CGAL checks below run in the ordinary and sanitizer passes.
check_skip=""
if [ -n "$VG_LOGS" ]; then
    run check cornell
    if [ "$rc" -eq 1 ] && grep -q 'rounding modes have no effect' "$T/err"; then
        pass "check under valgrind: refused, exit 1, $(head -n 1 "$T/err")"
        check_skip=1
    fi
fi
if [ -z "$check_skip" ]; then
    run check cornell
    if [ "$rc" -eq 0 ] && [ "$(value intersecting_pairs)" = 0 ] && [ "$(value degenerate)" = 0 ] &&
        [ "$(value contacts)" = 4 ]; then
        pass "check cornell: no errors (contacts $(value contacts), open edges $(value open_edges))"
    else
        fail "check cornell (exit $rc)"; show_err
    fi
    # the shipped office: furniture standing on the floor, a wall and the table (contacts only)
    OFFICE=${LRR_DATA_DIR:-data}/office.obj
    run check "$OFFICE"
    if [ "$rc" -eq 0 ] && [ "$(value triangles)" = 122 ] && [ "$(value degenerate)" = 0 ] &&
        [ "$(value intersecting_pairs)" = 0 ] && [ "$(value coplanar_overlaps)" = 0 ] &&
        [ "$(value inconsistent_components)" = 0 ] && [ "$(value contacts)" = 32 ] &&
        [ "$(value open_edges)" = 4 ]; then
        pass "check office.obj: no errors (32 contacts, 4 open edges: the light quad)"
    else
        fail "check $OFFICE (exit $rc): $(grep -E '^(triangles|degenerate|intersecting_pairs|coplanar_overlaps|contacts|open_edges|inconsistent_components):' "$T/out" | tr '\n' ' ')"
        show_err
    fi
    # a textured scene: the doctor reads it like any other (the closed cube is clean)
    run check "$BOXTEX"
    if [ "$rc" -eq 0 ] && [ "$(value triangles)" = 12 ] && [ "$(value open_edges)" = 0 ] &&
        [ "$(value result)" = clean ]; then
        pass "check BoxTextured.gltf (textured): clean"
    else
        fail "check $BOXTEX (exit $rc): result '$(value result)'"; show_err
    fi
    cat > "$T/broken.obj" <<'EOF'
v 0 0 0
v 2 0 0
v 0 2 0
v 0.5 -1 -1
v 0.5 -1 1
v 0.5 1 0
v 3 0 0
f 1 2 3
f 4 5 6
f 1 2 7
EOF
    run check "$T/broken.obj"
    if [ "$rc" -eq 1 ] && grep -q 'face 0 and face 1 intersect' "$T/out" &&
        grep -q 'face 2 is degenerate' "$T/out"; then
        pass "check on a broken OBJ exits 1 naming the faces"
    else
        fail "check broken.obj (exit $rc)"; sed 's/^/    out: /' "$T/out" | head -n 12
    fi
    cat > "$T/flipped.obj" <<'EOF'
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
v 5 5 5
v 6 5 5
f 1 4 3
f 1 3 2
f 5 6 7
f 5 7 8
f 1 2 6
f 1 5 6
f 4 8 7
f 4 7 3
f 1 5 8
f 1 8 4
f 2 3 7
f 2 7 6
f 9 10 9
EOF
    run check "$T/flipped.obj" --fix "$T/fixed.obj"
    if [ "$rc" -eq 1 ] && [ "$(value inconsistent_components)" = 1 ] &&
        grep -q 'face 5 is oriented against' "$T/out" && [ -s "$T/fixed.obj" ] &&
        [ -s "$T/fixed.mtl" ]; then
        pass "check --fix on a flipped face and a degenerate writes OBJ+MTL"
    else
        fail "check --fix (exit $rc)"; sed 's/^/    out: /' "$T/out" | head -n 12; show_err
    fi
    run check "$T/fixed.obj"
    if [ "$rc" -eq 0 ] && [ "$(value triangles)" = 12 ] && [ "$(value open_edges)" = 0 ] &&
        grep -qx 'result: clean' "$T/out"; then
        pass "check --fix output re-checks clean"
    else
        fail "re-check of the --fix output (exit $rc)"; sed 's/^/    out: /' "$T/out" | head -n 12
    fi
    # the repaired file keeps shared vertices (the 8 corners once: the two vertices only the
    # degenerate face used are gone), one usemtl for its one (default) material
    if [ "$(grep -c '^v ' "$T/fixed.obj")" = 8 ] && [ "$(grep -c '^f ' "$T/fixed.obj")" = 12 ] &&
        [ "$(grep -c '^usemtl ' "$T/fixed.obj")" = 1 ]; then
        pass "check --fix writes the 8 shared corners once, 12 faces, one usemtl"
    else
        fail "check --fix: $(grep -c '^v ' "$T/fixed.obj") vertices, $(grep -c '^f ' "$T/fixed.obj") faces, $(grep -c '^usemtl ' "$T/fixed.obj") usemtl"
    fi
    # objects and materials interleaved (box: pairs of red and blue faces alternating, one
    # face flipped, one degenerate on the box's own corners; panel: an open blue quad): the
    # repair keeps the names, the values, the objects, the shared vertices and the runs
    # (7: a usemtl per run, not per face)
    printf 'newmtl red\nKd 0.8 0.1 0.1\nnewmtl blue\nKd 0.1 0.2 0.7\nKe 2 2 3\n' > "$T/named.mtl"
    { echo 'mtllib named.mtl'; echo 'o box'
      sed -n '/^v /p' "$T/flipped.obj" | head -n 8
      awk '/^f / && n < 12 { if (n % 2 == 0) print (n % 4 ? "usemtl blue" : "usemtl red")
                             n++; print }' "$T/flipped.obj"
      echo 'usemtl red'; echo 'f 1 2 1'
      echo 'o panel'; echo 'usemtl blue'
      printf 'v 3 0 0\nv 4 0 0\nv 4 1 0\nv 3 1 0\nf 9 10 11\nf 9 11 12\n'; } > "$T/named.obj"
    run check "$T/named.obj" --fix "$T/named_fixed.obj"
    if [ "$rc" -eq 1 ] && [ "$(value triangles)" = 15 ] && [ "$(value degenerate)" = 1 ] &&
        [ "$(value inconsistent_components)" = 1 ]; then
        pass "check --fix on named.obj: 15 triangles, one degenerate, one flipped"
    else
        fail "check named.obj --fix (exit $rc): $(grep -E '^[a-z_]+: [0-9]+$' "$T/out" | tr '\n' ' ')"; show_err
    fi
    nf="$T/named_fixed"
    if [ "$(grep -c '^f ' "$nf.obj")" = 14 ] &&
        [ "$(grep -c '^v ' "$nf.obj")" = "$(obj_used_positions "$T/named.obj")" ] &&
        [ "$(grep -c '^usemtl ' "$nf.obj")" = "$(obj_runs "$T/named.obj")" ] &&
        [ "$(obj_runs "$T/named.obj")" = 7 ] &&
        [ "$(obj_names usemtl "$nf.obj")" = "blue red " ] &&
        [ "$(obj_names newmtl "$nf.mtl")" = "blue red " ] &&
        [ "$(obj_names g "$nf.obj")" = "box panel " ] &&
        awk '$1 == "newmtl" { m = $2 } $1 == "Kd" { kd[m] = $2 " " $3 " " $4 }
             $1 == "Ke" { ke[m] = $2 " " $3 " " $4 }
             END { exit !(kd["red"] == "0.8 0.1 0.1" && kd["blue"] == "0.1 0.2 0.7" &&
                          ke["blue"] == "2 2 3" && ke["red"] == "0 0 0") }' "$nf.mtl"; then
        pass "check --fix keeps vertex sharing ($(grep -c '^v ' "$nf.obj") vertices), objects, material names and values, one usemtl per run ($(grep -c '^usemtl ' "$nf.obj"))"
    else
        fail "check --fix names: $(grep -c '^f ' "$nf.obj") faces, $(grep -c '^v ' "$nf.obj") vertices (input $(obj_used_positions "$T/named.obj")), usemtl $(obj_names usemtl "$nf.obj")x$(grep -c '^usemtl ' "$nf.obj") (blocks $(obj_runs "$T/named.obj")), newmtl $(obj_names newmtl "$nf.mtl"), g $(obj_names g "$nf.obj")"
    fi
    run check "$nf.obj"
    if [ "$(value triangles)" = 14 ] && [ "$(value degenerate)" = 0 ] &&
        [ "$(value inconsistent_components)" = 0 ] && [ "$(value open_edges)" = 4 ]; then
        pass "check --fix output of named.obj re-checks: no degenerate, orientation consistent"
    else
        fail "re-check of named_fixed.obj (exit $rc): $(grep -E '^[a-z_]+: [0-9]+$' "$T/out" | tr '\n' ' ')"
    fi
    # atomic: with writes failing (file size limit, SIGXFSZ ignored so write() fails with
    # EFBIG) the old files stay as they were and no temporary is left behind
    mkdir "$T/atomic"
    echo old > "$T/atomic/out.obj"
    echo old > "$T/atomic/out.mtl"
    (trap '' XFSZ; ulimit -f 1; lrr_exec check "${LRR_DATA_DIR:-data}/office.obj" \
        --fix "$T/atomic/out.obj" >"$T/out" 2>"$T/err")
    rc=$?
    if [ "$rc" -eq 1 ] && [ "$(cat "$T/atomic/out.obj")" = old ] &&
        [ "$(cat "$T/atomic/out.mtl")" = old ] && [ "$(ls "$T/atomic" | wc -l)" = 2 ] &&
        grep -q 'out\.' "$T/err"; then
        pass "check --fix failing to write leaves the old files and no temporary ($(head -n 1 "$T/err"))"
    else
        fail "check --fix under a file size limit (exit $rc): $(ls "$T/atomic" | tr '\n' ' ')"; show_err
    fi
    run check cornell --strict
    expect_rc 1 "check cornell --strict (warnings count)"
    # the real scenes in data/scenes (counts from their SOURCE.md, data/README.md): the IFC
    # house's solids intersect and touch (exit 1, errors), the bunny room only has open edges
    # (the scan's holes and the light quad); 0.7 s each here
    # an open floor quad facing down, away from its room: flagged as a warning
    run check "${LRR_SRCDIR:-.}/tests/data/room_floor_flipped.obj"
    if [ "$rc" -eq 0 ] && [ "$(value upside_down_sheets)" = 1 ] &&
        grep -q '^warning: face 10 is in an open sheet that looks upside down' "$T/out" &&
        grep -qx 'result: warnings only' "$T/out"; then
        pass "check names the upside-down floor quad (warning)"
    else
        fail "check room_floor_flipped.obj (exit $rc)"; sed 's/^/    out: /' "$T/out" | head -n 14
    fi
    run check "${LRR_SRCDIR:-.}/tests/data/room_floor.obj"
    if [ "$rc" -eq 0 ] && [ "$(value upside_down_sheets)" = 0 ]; then
        pass "check: the floor facing its room is not flagged"
    else
        fail "check room_floor.obj (exit $rc): upside_down_sheets '$(value upside_down_sheets)'"
    fi
    fzk="${LRR_DATA_DIR:-data}/scenes/fzk_haus.obj"
    run check "$fzk" --fix "$T/fzk_fixed.obj"
    if [ "$rc" -eq 1 ] && [ "$(value triangles)" = 35910 ] && [ "$(value degenerate)" = 3 ] &&
        [ "$(value intersecting_pairs)" = 10825 ] && [ "$(value coplanar_overlaps)" = 1263 ] &&
        [ "$(value contacts)" = 14806 ] && [ "$(value open_edges)" = 3207 ] &&
        [ "$(value inconsistent_components)" = 35 ] && [ "$(value upside_down_sheets)" = 6 ] &&
        grep -qx 'result: errors' "$T/out"; then
        pass "check fzk_haus.obj: 10825 intersecting pairs, 14806 contacts, 3207 open edges (exit 1)"
    else
        fail "check fzk_haus.obj (exit $rc): $(grep -E '^[a-z_]+: [0-9]+$' "$T/out" | tr '\n' ' ')"; show_err
    fi
    # its repair: the 3 degenerate triangles gone, every other one written on the file's
    # shared vertices, with its 12 materials by name, one usemtl per run (one each)
    if [ "$(grep -c '^f ' "$T/fzk_fixed.obj")" = 35907 ] &&
        [ "$(grep -c '^v ' "$T/fzk_fixed.obj")" = "$(obj_used_positions "$fzk")" ] &&
        [ "$(grep -c '^usemtl ' "$T/fzk_fixed.obj")" = "$(obj_runs "$fzk")" ] &&
        [ "$(obj_names usemtl "$T/fzk_fixed.obj")" = "$(obj_names usemtl "$fzk")" ] &&
        [ "$(obj_names newmtl "$T/fzk_fixed.mtl")" = "$(obj_names usemtl "$fzk")" ]; then
        pass "check --fix fzk_haus.obj: 35907 faces on $(grep -c '^v ' "$T/fzk_fixed.obj") shared vertices, $(grep -c '^usemtl ' "$T/fzk_fixed.obj") usemtl, the file's material names"
    else
        fail "check --fix fzk_haus.obj: $(grep -c '^f ' "$T/fzk_fixed.obj") faces, $(grep -c '^v ' "$T/fzk_fixed.obj") vertices (input $(obj_used_positions "$fzk")), $(grep -c '^usemtl ' "$T/fzk_fixed.obj") usemtl (blocks $(obj_runs "$fzk"))"
    fi
    # and it loads back as the same scene: lrr info's triangles, patches, area, emitters
    # and bounds agree; only the 3 zero-area triangles lrr skipped on input are gone
    run info "$fzk"
    sed '1d; s/^skipped: 3$/skipped: 0/' "$T/out" > "$T/fzk_info"
    run info "$T/fzk_fixed.obj"
    if [ "$rc" -eq 0 ] && sed 1d "$T/out" | cmp -s - "$T/fzk_info" &&
        grep -qx 'triangles: 35907' "$T/out"; then
        pass "check --fix fzk_haus.obj loads back: the same triangles, area, emitters and bounds as the input"
    else
        fail "lrr info of the fixed fzk_haus.obj (exit $rc) differs:"; sed 1d "$T/out" | diff "$T/fzk_info" - | sed 's/^/    /'
    fi
    run check "${LRR_DATA_DIR:-data}/scenes/bunny_room.obj"
    if [ "$rc" -eq 0 ] && [ "$(value triangles)" = 72525 ] && [ "$(value intersecting_pairs)" = 0 ] &&
        [ "$(value contacts)" = 0 ] && [ "$(value open_edges)" = 227 ] &&
        [ "$(value inconsistent_components)" = 0 ] && [ "$(value upside_down_sheets)" = 0 ] &&
        grep -qx 'result: warnings only' "$T/out"; then
        pass "check bunny_room.obj: 72525 triangles, 227 open edges, warnings only"
    else
        fail "check bunny_room.obj (exit $rc): $(grep -E '^[a-z_]+: [0-9]+$' "$T/out" | tr '\n' ' ')"; show_err
    fi
fi
run check
expect_rc 2 "check without a scene"
run check cornell --max-report x
expect_rc 2 "check --max-report x"

# ---------------------------------------------------------------- adaptive hierarchy
ADFILE="$T/adaptive.lrr"
run preprocess cornell -o "$ADFILE" --patches 200 --adaptive 90 --adaptive-samples 64 \
    --hemicube 32 --threads 2
if [ "$rc" -eq 0 ] && [ "$(value d)" = 0 ] && [ "$(value k)" -le 90 ] &&
    [ "$(value k)" -gt 87 ] && [ "$(value d_min)" -lt "$(value d_max)" ] &&
    [ -n "$(value selection_seconds)" ]; then
    pass "preprocess --adaptive 90: k = $(value k), d $(value d_min)..$(value d_max)"
else
    fail "preprocess --adaptive (exit $rc)"; show_err; sed 's/^/    out: /' "$T/out" | head -n 8
fi
adk=$(value k)
run solve "$ADFILE" --csv "$T/adaptive.csv" --repeat 1
# the CSV's patch column must run 0..k-1, non-decreasing, over contiguous subpatches
if [ "$rc" -eq 0 ] && awk -F, -v k="$adk" 'NR == 1 { next }
        { if ($2 < last || $2 > last + 1) bad = 1; last = $2 }
        END { exit !(bad == 0 && last == k - 1) }' "$T/adaptive.csv"; then
    pass "solve --csv on an adaptive operator: patch column covers 0..$((adk - 1))"
else
    fail "solve --csv on an adaptive operator (exit $rc)"; show_err
fi
run preprocess cornell -o "$ADFILE" --patches 200 --levels 2 --adaptive 90
expect_rc 2 "--adaptive with --levels 2 is rejected"
run preprocess cornell -o "$ADFILE" --adaptive-split area
expect_rc 2 "--adaptive-split without --adaptive is rejected"
run preprocess cornell -o "$ADFILE" --patches 200 --adaptive 90 --adaptive-split depth
expect_rc 2 "--adaptive-split depth is rejected"
run preprocess cornell -o "$ADFILE" --patches 200 --adaptive 5
expect_rc 1 "--adaptive below the triangle count is an error"
if grep -q "between" "$T/err"; then pass "the error names the allowed range"; else fail "no range in: $(cat "$T/err")"; fi
# ---------------------------------------------------------------- cluster hierarchy
CLFILE="$T/clusters.lrr"
run preprocess cornell -o "$CLFILE" --patches 600 --levels 0 --clusters 40 \
    --adaptive-samples 64 --hemicube 16 --threads 2
if [ "$rc" -eq 0 ] && [ "$(value hierarchy)" = clusters ] && [ "$(value k)" = 40 ] &&
    [ "$(value d)" = 0 ] && [ "$(value d_min)" -lt "$(value d_max)" ]; then
    pass "preprocess --clusters 40: k = 40, d $(value d_min)..$(value d_max)"
else
    fail "preprocess --clusters (exit $rc)"; show_err; sed 's/^/    out: /' "$T/out" | head -n 8
fi
# the CSV comes out in the scene's order: the same rows as the reference's, so compare works
run solve "$CLFILE" --csv "$T/clusters.csv" --repeat 1
run reference cornell --method direct --patches 600 --levels 0 --hemicube 16 \
    --csv "$T/clusters-ref.csv"
run compare "$T/clusters.csv" "$T/clusters-ref.csv"
l2=$(value rel_l2)
if [ "$rc" -eq 0 ] && awk -v x="$l2" 'BEGIN { exit !(x > 0 && x < 0.05) }'; then
    pass "clusters against the direct n×n solve, rows mapped to the scene's order: rel_l2 $l2"
else
    fail "compare clusters/direct (exit $rc, rel_l2 '$l2')"; show_err
fi
run preprocess cornell -o "$CLFILE" --clusters 40 --adaptive 40
expect_rc 2 "--clusters with --adaptive is rejected"
run preprocess cornell -o "$CLFILE" --clusters 0
expect_rc 2 "--clusters 0 is rejected"
run preprocess cornell -o "$CLFILE" --clusters 40 --levels 1
expect_rc 2 "--clusters with --levels 1 is rejected"
# ---------------------------------------------------------------- moving lights
LTFILE="$T/lights.lrr"
run preprocess cornell -o "$LTFILE" --patches 100 --levels 1 --hemicube 16
# a point light near the green wall (x = 0) lights the x < 278 half more than the other
run solve "$LTFILE" --light 'point pos=60,300,279 rgb=20000' --no-scene-emission \
    --csv "$T/light-left.csv" --repeat 1
if [ "$rc" -eq 0 ] && [ "$(value lights)" = 1 ] && [ -n "$(value direct_light_seconds)" ] &&
    awk -F, 'NR > 1 { if ($4 < 278) l += $3 * $10; else r += $3 * $10 }
             END { exit !(l > 1.5 * r && r > 0) }' "$T/light-left.csv"; then
    pass "solve --light point near the x = 0 wall: that half gets more light"
else
    fail "solve --light (exit $rc)"; show_err
fi
run solve "$LTFILE" --light 'spot pos=278,500,279 dir=0,-1,0 angle=20 soft=5 rgb=1e5' \
    --light 'sun dir=0,1,0 rgb=1' --light 'area pos=278,540,279 u=100,0,0 v=0,0,100 rgb=5'
if [ "$rc" -eq 0 ] && [ "$(value lights)" = 3 ]; then
    pass "solve with a spot, a sun and an area light"
else
    fail "solve with three lights (exit $rc)"; show_err
fi
# animate: a light crossing the box, one picture per frame. The script is the one grammar
# of lrr view --script too (tools/cli_script.c): statements run in order, so emitters off
# comes before the frames it is meant for, and the path moves its light during them.
cat > "$T/move.txt" <<'EOS'
# from the green wall to the red one
light point pos=60,300,279 rgb=20000
light sun dir=0,1,0 rgb=0.5
emitters off
path 0 60,300,279 278,300,279 500,300,279
frames 3
EOS
run animate "$LTFILE" --lights "$T/move.txt" -o "$T/frames" --width 64 --height 64
if [ "$rc" -eq 0 ] && [ "$(value frames)" = 3 ] && [ -s "$T/frames/frame_0000.png" ] &&
    [ -s "$T/frames/frame_0002.png" ] && [ ! -e "$T/frames/frame_0003.png" ] &&
    [ "$(grep -c '^frame: ' "$T/out")" = 3 ] && [ -n "$(value exposure)" ]; then
    pass "animate: 3 frames written, the split printed per frame"
else
    fail "animate (exit $rc)"; show_err
fi
printf 'light point pos=1,2,3\npath 0 1,2,3\n' > "$T/bad.txt"
run animate "$LTFILE" --lights "$T/bad.txt" -o "$T/frames"
expect_rc 2 "animate: a path of one point is rejected"
if grep -q "bad.txt' line 2" "$T/err"; then pass "the error names the file and line"; else fail "no line in: $(cat "$T/err")"; fi
# The frames a script draws: frames N, and the frames=N of move and path (a move with no
# frames after it is an error, not a silent no-op); the viewer's input is refused.
printf 'light point pos=60,300,279 rgb=20000\nmove 0 pos=500,300,279 frames=2\npath 0 1,2,3 4,5,6\nframes 1\nremove 0\nframes 2\n' > "$T/count.txt"
run animate "$LTFILE" --lights "$T/count.txt" -o "$T/count" --width 16 --height 16
if [ "$rc" -eq 0 ] && [ "$(value frames)" = 5 ] && [ -s "$T/count/frame_0004.png" ] &&
    [ ! -e "$T/count/frame_0005.png" ]; then
    pass "animate: move frames=2 + frames 1 + frames 2 = 5 pictures"
else
    fail "animate: frames $(value frames) (exit $rc)"; show_err
fi
for bad in 'move 0 pos=1,2,3' 'frames 3 4' 'remove 1' 'click 10 10' 'key N' 'screenshot x.png' \
    'fly 0'; do
    printf 'light point pos=60,300,279 rgb=20000\nframes 1\n%s\n' "$bad" > "$T/bad.txt"
    run animate "$LTFILE" --lights "$T/bad.txt" -o "$T/frames"
    if [ "$rc" -eq 2 ] && grep -q "bad.txt' line 3" "$T/err"; then
        pass "animate: '$bad' is refused naming line 3"
    else
        fail "animate: '$bad': exit $rc: $(cat "$T/err")"
    fi
done
# In order: the automatic exposure is keyed on the first frame after 'exposure 0', so
# emitters switched on before it give the exposure of a script that had them on all along,
# not that of the first frame, drawn with them off.
printf 'light point pos=60,300,279 rgb=20000\nemitters %s\nframes 1\n' on > "$T/on.txt"
printf 'light point pos=60,300,279 rgb=20000\nemitters %s\nframes 1\n' off > "$T/off.txt"
printf 'light point pos=60,300,279 rgb=20000\nemitters off\nframes 1\nemitters on\nexposure 0\nframes 1\n' > "$T/both.txt"
x_on=""; x_off=""; x_both=""
run animate "$LTFILE" --lights "$T/on.txt" -o "$T/e1" --width 16 --height 16 && x_on=$(value exposure)
run animate "$LTFILE" --lights "$T/off.txt" -o "$T/e2" --width 16 --height 16 && x_off=$(value exposure)
run animate "$LTFILE" --lights "$T/both.txt" -o "$T/e3" --width 16 --height 16 && x_both=$(value exposure)
if [ -n "$x_on" ] && [ "$x_both" = "$x_on" ] && [ "$x_both" != "$x_off" ]; then
    pass "animate: statements run in order (exposure $x_both = emitters on, not $x_off)"
else
    fail "animate: exposures on '$x_on', off '$x_off', off then on '$x_both'"
fi
run animate "$LTFILE" -o "$T/frames"
expect_rc 2 "animate without --lights is rejected"
run solve "$LTFILE" --light 'lamp pos=1,2,3'
expect_rc 2 "--light with an unknown kind is rejected"
run solve "$LTFILE" --light 'point pos=1,2'
expect_rc 2 "--light with a two-component position is rejected"
run solve "$LTFILE" --no-scene-emission
expect_rc 2 "--no-scene-emission without --probe or --light is rejected"
run solve "$LTFILE" --light 'spot pos=0,0,0 dir=0,0,0'
expect_rc 1 "--light spot with a zero direction is an error"
if grep -q "direction" "$T/err"; then pass "the error names the field"; else fail "no field in: $(cat "$T/err")"; fi
# ---------------------------------------------------------------- valgrind
if [ -n "$VG_LOGS" ]; then
    dirty=""
    logs=0
    for f in "$VG_LOGS"/*.log; do
        [ -e "$f" ] || continue
        logs=$((logs + 1))
        [ -s "$f" ] && dirty="$dirty $f"
    done
    if [ "$logs" -eq 0 ]; then
        fail "valgrind: no logs in $VG_LOGS"
    elif [ -z "$dirty" ]; then
        pass "valgrind: $logs lrr invocations, no memory errors, no definite or indirect leaks"
    else
        fail "valgrind: reports in$dirty"
        shown=0
        for f in $dirty; do
            shown=$((shown + 1))
            [ "$shown" -le 5 ] && sed 's/^/    /' "$f" | head -n 60
        done
    fi
fi

# ---------------------------------------------------------------- summary
if [ "$failures" -eq 0 ]; then
    rm -rf "$T"
    echo "all $checks checks passed"
    exit 0
fi
echo "$failures of $checks checks failed (files kept in $T)"
exit 1
