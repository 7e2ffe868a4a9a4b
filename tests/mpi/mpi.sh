#!/bin/sh
# The MPI tests (configure --with-mpi; docs/MPI.md), each under mpirun with a timeout so
# that a hang fails instead of blocking: the library's distributed solver against the
# serial one with 1 to 4 ranks (test_mpi_solve) and its fault cases (test_mpi_faults), then
# `mpirun -np P lrr solve` against `lrr solve` (same CSV within 1e-6, same summary) and its
# failures (rank 0 alone prints the error), rank 0's peak memory (no whole F̄ there),
# `mpirun lrr render` against `lrr render`, the distributed build and path tracer
# (test_mpi_build, test_mpi_build_save; `mpirun lrr preprocess [--verify]` and `mpirun lrr reference --method
# path-trace` against the serial commands), and a smoke run of lrr-bench mpi. Root may run them (--allow-run-as-root); more
# ranks than cores (--oversubscribe) is the point on a 2-core machine.
# Environment: LRR_MPIRUN, LRR_MPI_TESTS (the test programs' folder), LRR_BIN,
# LRR_TEST_TMP (as make check sets them).
MPIRUN=${LRR_MPIRUN:-mpirun}
DIR=${LRR_MPI_TESTS:-tests/mpi}
LRR=${LRR_BIN:-./lrr}
# A test of a few seconds: 120 s means a hang (the programs' own alarm is 60 s).
LIMIT=120
command -v "$MPIRUN" >/dev/null 2>&1 || { echo "SKIP: no mpirun"; exit 77; }
command -v timeout >/dev/null 2>&1 || { echo "SKIP: no timeout(1)"; exit 77; }
checks=0
failures=0
pass() { checks=$((checks + 1)); echo "PASS: $1"; }
fail() { checks=$((checks + 1)); failures=$((failures + 1)); echo "FAIL: $1"; }
# max_rel A B: `lrr compare`'s max_rel of CSV A against B into $max ($T/cmp keeps the
# report), and whether it is a number <= 1e-6
max_rel() {
    "$LRR" compare "$1" "$2" >"$T/cmp" 2>&1
    max=$(sed -n 's/^max_rel: //p' "$T/cmp")
    awk -v v="$max" 'BEGIN { exit !(v ~ /^[0-9.eE+-]+$/ && v + 0 <= 1e-6) }'
}
T=$(mktemp -d "${LRR_TEST_TMP:-/tmp}/mpi.XXXXXX") || exit 1
trap 'rm -rf "$T"' EXIT
export LRR_TEST_TMP="$T"
# Sanitizer builds (make check sets LSAN_OPTIONS): Open MPI's own allocations are
# suppressed by library name (tests/lsan.supp), which needs its plugins still loaded at exit
# and whole stacks (Open MPI has no frame pointers for the fast unwinder).
export OMPI_MCA_mca_base_component_disable_dlclose=1
if [ -n "${LSAN_OPTIONS:-}" ]; then
    export LSAN_OPTIONS="$LSAN_OPTIONS:fast_unwind_on_malloc=0"
fi
# mpi NP CMD...: CMD on NP ranks, stdout to $T/out, stderr to $T/err, exit status in rc
mpi() {
    np=$1
    shift
    timeout -k 5 "$LIMIT" "$MPIRUN" --oversubscribe --allow-run-as-root -np "$np" "$@" \
        >"$T/out" 2>"$T/err"
    rc=$?
}
value() { sed -n "s/^$1: //p" "$T/out" | head -n 1; }

# ---------------------------------------------------------------- the library
# its ABI: the LRR_API functions of lrr_mpi.h = lib/liblrr_mpi.map = nm -D, node LRR_MPI_0,
# and liblrr itself without any MPI dependency
top=${LRR_SRCDIR:-.}
so=${LRR_LIBDIR:-.libs}/liblrr_mpi.so
if [ -f "$so" ] && command -v nm >/dev/null 2>&1; then
    sed -n 's/^LRR_API[^(]*[^a-z0-9_]\(lrr_mpi_[a-z0-9_]*\)(.*/\1/p' "$top/include/lrr_mpi.h" |
        sort -u >"$T/header"
    sed -n 's/^[[:space:]]*\(lrr_mpi_[a-z0-9_]*\);.*/\1/p' "$top/lib/liblrr_mpi.map" | sort -u >"$T/map"
    nm -D --defined-only "$so" | awk '{print $3}' | grep -v '^LRR_' | sed 's/@@LRR_MPI_[0-9.]*$//' |
        sort -u >"$T/so"
    if [ -s "$T/header" ] && cmp -s "$T/header" "$T/map" && cmp -s "$T/map" "$T/so"; then
        pass "liblrr_mpi exports exactly lrr_mpi.h's $(wc -l <"$T/header") functions, nodes LRR_MPI_0*"
    else
        diff "$T/header" "$T/map"; diff "$T/map" "$T/so"
        fail "liblrr_mpi's exports: lrr_mpi.h, lib/liblrr_mpi.map and nm -D differ"
    fi
    if ldd "${LRR_LIBDIR:-.libs}/liblrr.so" | grep -qi mpi; then
        fail "liblrr.so depends on MPI: $(ldd "${LRR_LIBDIR:-.libs}/liblrr.so" | grep -i mpi)"
    else
        pass "liblrr.so has no MPI dependency (ldd)"
    fi
fi
for np in 1 2 3 4; do
    mpi "$np" "$DIR/test_mpi_solve"
    grep -E '^(PASS|FAIL): .*(max rel diff|failed checks)' "$T/out"
    if [ "$rc" -eq 0 ]; then pass "test_mpi_solve on $np ranks"
    else cat "$T/out" "$T/err"; fail "test_mpi_solve on $np ranks: exit $rc"; fi
done
for np in 1 2 3 4; do
    mpi "$np" "$DIR/test_mpi_build"
    grep -E '^FAIL|failed checks|(raster|clusters).*bit for bit' "$T/out"
    if [ "$rc" -eq 0 ]; then pass "test_mpi_build on $np ranks"
    else cat "$T/out" "$T/err"; fail "test_mpi_build on $np ranks: exit $rc"; fi
done
for np in 1 2 3 4; do
    mpi "$np" "$DIR/test_mpi_build_save"
    grep -E '^FAIL|failed checks|(timings|budget .* on|write failing.*every)' "$T/out"
    if [ "$rc" -eq 0 ]; then pass "test_mpi_build_save on $np ranks"
    else cat "$T/out" "$T/err"; fail "test_mpi_build_save on $np ranks: exit $rc"; fi
done
# G inverted with ScaLAPACK (LRR_MPI_FACTOR; blocks of 3 so that they cycle over the grid):
# the file the serial one but for M and its condition estimates, those within rounding
if "$LRR" --version 2>/dev/null | grep -q ' scalapack'; then
    for np in 1 2 3 4; do
        LRR_MPI_FACTOR=scalapack LRR_MPI_SCALAPACK_NB=3 mpi "$np" "$DIR/test_mpi_build_save"
        grep -E '^FAIL|failed checks|ScaLAPACK: the root' "$T/out"
        if [ "$rc" -eq 0 ]; then pass "test_mpi_build_save with ScaLAPACK on $np ranks"
        else cat "$T/out" "$T/err"; fail "test_mpi_build_save with ScaLAPACK on $np ranks: exit $rc"; fi
    done
else
    echo "SKIP: test_mpi_build_save with ScaLAPACK (built without it)"
fi
for np in 1 2 4; do
    mpi "$np" "$DIR/test_mpi_faults"
    grep -E "message names the cause|^# " "$T/out"
    if [ "$rc" -eq 0 ]; then pass "test_mpi_faults on $np ranks"
    else cat "$T/out" "$T/err"; fail "test_mpi_faults on $np ranks: exit $rc"; fi
done

# ---------------------------------------------------------------- the tool
OP="$T/cornell.lrr"
"$LRR" preprocess cornell --patches 54 --levels 1 --hemicube 16 --seed 3 -o "$OP" \
    >/dev/null 2>"$T/err" || { cat "$T/err"; fail "lrr preprocess for the CLI checks"; exit 1; }
LIGHT='point pos=278,400,279 rgb=30000'
"$LRR" solve "$OP" --repeat 2 --csv "$T/serial.csv" >"$T/serial.out" 2>"$T/err" &&
    "$LRR" solve "$OP" --repeat 2 --light "$LIGHT" --csv "$T/serial-light.csv" \
        >"$T/serial-light.out" 2>>"$T/err" ||
    { cat "$T/err"; fail "serial lrr solve"; exit 1; }
for np in 1 2 3 4; do
    mpi "$np" "$LRR" solve "$OP" --repeat 2 --csv "$T/mpi$np.csv"
    same=1
    for key in n k d storage; do
        [ "$(value "$key")" = "$(sed -n "s/^$key: //p" "$T/serial.out")" ] || same=0
    done
    # the means are sums of the same B: equal within the CSV's 1e-6
    for key in mean_b_r mean_b_g mean_b_b max_b; do
        awk -v a="$(value "$key")" -v b="$(sed -n "s/^$key: //p" "$T/serial.out")" \
            'BEGIN { d = a - b; if (d < 0) d = -d; exit !(b + 0 > 0 && d <= 1e-6 * b) }' ||
            same=0
    done
    if [ "$rc" -eq 0 ] && [ "$(value ranks)" = "$np" ] && [ "$same" -eq 1 ] &&
        [ "$(grep -c '^n: ' "$T/out")" -eq 1 ]; then
        pass "mpirun -np $np lrr solve: rank 0 alone prints; n, k, d, storage as the serial run, mean and max B within 1e-6"
    else
        cat "$T/out" "$T/err"; fail "mpirun -np $np lrr solve: exit $rc"
    fi
    if max_rel "$T/mpi$np.csv" "$T/serial.csv"; then
        pass "mpirun -np $np lrr solve --csv = lrr solve --csv: max_rel $max <= 1e-6"
    else
        cat "$T/cmp"; fail "mpirun -np $np lrr solve --csv against the serial CSV: max_rel '$max'"
    fi
done
mpi 3 "$LRR" solve "$OP" --repeat 2 --light "$LIGHT" --csv "$T/mpi-light.csv"
if max_rel "$T/mpi-light.csv" "$T/serial-light.csv" && [ "$rc" -eq 0 ] &&
    [ "$(value lights)" = 1 ]; then
    pass "mpirun -np 3 lrr solve --light: each rank's rows of the direct light (lrr_lighting_direct_rows), max_rel $max <= 1e-6"
else
    cat "$T/out" "$T/err" "$T/cmp"; fail "mpirun -np 3 lrr solve --light: exit $rc, max_rel '$max'"
fi
# a probe (its direct light scattered from rank 0) and two lights (each rank its rows), with
# and without the scene's emission: E = emission + (probe + lights) in the serial order, so
# one rank writes the serial CSV byte for byte (its frame is the serial one) and two within
# the distributed frame's rounding
PROBE="$top/data/probes/courtyard.hdr"
AREA='area pos=278,500,279 u=100,0,0 v=0,0,-100 samples=4 rgb=40,30,20'
for extra in "" --no-scene-emission; do
    "$LRR" solve "$OP" --probe "$PROBE" --light "$LIGHT" --light "$AREA" $extra \
        --csv "$T/serial-pl.csv" >/dev/null 2>"$T/err" || { cat "$T/err"; fail "serial lrr solve --probe --light"; }
    mpi 1 "$LRR" solve "$OP" --probe "$PROBE" --light "$LIGHT" --light "$AREA" $extra \
        --csv "$T/mpi-pl.csv"
    if [ "$rc" -eq 0 ] && cmp -s "$T/mpi-pl.csv" "$T/serial-pl.csv"; then
        pass "mpirun -np 1 lrr solve --probe --light --light $extra: the serial CSV byte for byte"
    else
        cat "$T/out" "$T/err"; fail "mpirun -np 1 lrr solve --probe --light $extra: exit $rc or another CSV"
    fi
    mpi 2 "$LRR" solve "$OP" --probe "$PROBE" --light "$LIGHT" --light "$AREA" $extra \
        --csv "$T/mpi-pl.csv"
    if max_rel "$T/mpi-pl.csv" "$T/serial-pl.csv" && [ "$rc" -eq 0 ] &&
        [ "$(value lights)" = 2 ]; then
        pass "mpirun -np 2 lrr solve --probe --light --light $extra: max_rel $max <= 1e-6"
    else
        cat "$T/out" "$T/err" "$T/cmp"; fail "mpirun -np 2 lrr solve --probe --light $extra: exit $rc, max_rel '$max'"
    fi
done

# mpirun lrr render: the distributed solve, then rank 0 draws; the radiosity it drew (--csv)
# within 1e-6 of the serial render's, and the picture of the asked size (PNG: IHDR's width
# and height, big-endian at bytes 16..23; EXR: its magic number)
"$LRR" render "$OP" -o "$T/serial.png" --width 48 --height 32 --light "$LIGHT" \
    --csv "$T/render-serial.csv" >/dev/null 2>"$T/err" || { cat "$T/err"; fail "serial lrr render"; }
for np in 2 3; do
    mpi "$np" "$LRR" render "$OP" -o "$T/mpi.png" --width 48 --height 32 --light "$LIGHT" \
        --csv "$T/render-mpi.csv"
    size=$(od -An -tx1 -j16 -N8 "$T/mpi.png" 2>/dev/null | tr -d ' \n')
    if max_rel "$T/render-mpi.csv" "$T/render-serial.csv" && [ "$rc" -eq 0 ] &&
        [ "$(value ranks)" = "$np" ] && [ "$(grep -c '^output: ' "$T/out")" -eq 1 ] &&
        [ "$size" = "0000003000000020" ]; then
        pass "mpirun -np $np lrr render --light: rank 0 alone draws a 48x32 PNG, its B within $max of the serial render's"
    else
        cat "$T/out" "$T/err" "$T/cmp"; fail "mpirun -np $np lrr render: exit $rc, size '$size', max_rel '$max'"
    fi
done
mpi 2 "$LRR" render "$OP" -o "$T/mpi.exr" --width 16 --height 16
if [ "$rc" -eq 0 ] && [ "$(od -An -tx1 -N4 "$T/mpi.exr" | tr -d ' ')" = "762f3101" ]; then
    pass "mpirun -np 2 lrr render -o X.exr: an OpenEXR file"
else
    cat "$T/out" "$T/err"; fail "mpirun -np 2 lrr render -o X.exr: exit $rc"
fi
mpi 2 "$LRR" render "$T/missing.lrr" -o "$T/missing.png"
if [ "$rc" -eq 1 ] && [ "$(grep -c "missing.lrr" "$T/err")" -eq 1 ] && [ ! -e "$T/missing.png" ]; then
    pass "mpirun -np 2 lrr render of a missing file: exit 1, once: $(head -n 1 "$T/err")"
else
    cat "$T/out" "$T/err"; fail "mpirun -np 2 lrr render of a missing file: exit $rc"
fi

# rank 0 holds the operator without F̄ (lrr_operator_load_head) beside its own rows: its peak
# RSS stays within half of F̄'s dense bytes of rank 1's (a whole load there would add all of
# F̄; Cornell at 1008 patches × 16: F̄ 65 MB, M 12 MB, rank 0 about 16 MB above rank 1, a
# whole load 80 MB). Not under AddressSanitizer, whose shadow and quarantine are not the heap.
if [ -z "${ASAN_OPTIONS:-}" ] && /usr/bin/time -f %M true >/dev/null 2>&1; then
    BIG="$T/cornell-1008.lrr"
    "$LRR" preprocess cornell --patches 1000 --levels 2 --hemicube 8 --seed 3 -o "$BIG" \
        >/dev/null 2>"$T/err" || { cat "$T/err"; fail "lrr preprocess for the memory check"; }
    # shellcheck disable=SC2016 # expanded by the ranks' sh
    # each rank's figure in a file of its own (their stderr lines interleave)
    mpi 2 sh -c 'OMP_NUM_THREADS=1 exec /usr/bin/time -o "$2.$OMPI_COMM_WORLD_RANK" -f %M \
        "$0" solve "$1" --repeat 1' "$LRR" "$BIG" "$T/peak_kb"
    p0=$(cat "$T/peak_kb.0" 2>/dev/null)
    p1=$(cat "$T/peak_kb.1" 2>/dev/null)
    half_kb=$(($(value n) * $(value k) * 4 / 2048))
    if [ "$rc" -eq 0 ] && [ -n "$p0" ] && [ -n "$p1" ] && [ "$p0" -lt $((p1 + half_kb)) ]; then
        pass "mpirun -np 2 lrr solve: rank 0 peaks at $p0 KB, rank 1 at $p1 KB (F̄: $((2 * half_kb)) KB)"
    else
        cat "$T/out" "$T/err"
        fail "mpirun -np 2 lrr solve: rank 0 peaks at '$p0' KB, rank 1 at '$p1' KB, F̄/2 $half_kb KB"
    fi
fi

# failures: exit 1 (2 for usage) on every rank, one message, from rank 0, within LIMIT
head -c 4000 "$OP" >"$T/truncated.lrr"
for case in "truncated.lrr:truncated" "missing.lrr:cannot open"; do
    file=${case%%:*}
    want=${case#*:}
    mpi 2 "$LRR" solve "$T/$file"
    if [ "$rc" -eq 1 ] && [ "$(grep -c '^lrr: ' "$T/err")" -eq 1 ] && grep -q "$want" "$T/err"; then
        pass "mpirun -np 2 lrr solve $file: exit 1, one message: $(head -n 1 "$T/err")"
    else
        cat "$T/out" "$T/err"; fail "mpirun -np 2 lrr solve $file: exit $rc"
    fi
done
for opt in "--backend opencl" "--path sparse" "--fbar dense" "--m f32"; do
    # shellcheck disable=SC2086 # opt is an option and its value
    mpi 2 "$LRR" solve "$OP" $opt
    if [ "$rc" -eq 2 ] && [ "$(grep -c "not available across MPI ranks" "$T/err")" -eq 1 ]; then
        pass "mpirun -np 2 lrr solve $opt: exit 2, once: $(head -n 1 "$T/err")"
    else
        cat "$T/out" "$T/err"; fail "mpirun -np 2 lrr solve $opt: exit $rc"
    fi
done

# mpirun lrr preprocess: the serial file but for its timings (test_mpi_build --same), for
# the quadtree, for clusters (the selection replicated on every rank), in binary16 as strips
# (F̄ stays on the ranks: lrr_mpi_operator_build_save) and with --verify (the operator
# gathered on rank 0, its path tracing across the ranks: the same figures, in the file)
for args in "--patches 54 --levels 1" "--clusters 12" "--clusters 40 --storage f16 --fbar sparse" \
    "--patches 54 --levels 1 --verify 16"; do
    # shellcheck disable=SC2086 # args are options
    "$LRR" preprocess cornell $args --hemicube 16 --seed 3 -o "$T/pre-serial.lrr" \
        >"$T/pre-serial.out" 2>"$T/err" || { cat "$T/err"; fail "lrr preprocess $args"; }
    for np in 2 3; do
        # shellcheck disable=SC2086
        mpi "$np" "$LRR" preprocess cornell $args --hemicube 16 --seed 3 -o "$T/pre-mpi.lrr"
        if [ "$rc" -eq 0 ] && [ "$(value ranks)" = "$np" ] && [ "$(grep -c '^n: ' "$T/out")" -eq 1 ] &&
            [ "$(value n)" = "$(sed -n 's/^n: //p' "$T/pre-serial.out")" ] &&
            [ "$(value verify_rel_l2)" = "$(sed -n 's/^verify_rel_l2: //p' "$T/pre-serial.out")" ] &&
            "$DIR/test_mpi_build" --same "$T/pre-mpi.lrr" "$T/pre-serial.lrr" >"$T/same"; then
            pass "mpirun -np $np lrr preprocess $args: rank 0 alone prints, the serial file but for its timings"
        else
            cat "$T/out" "$T/err" "$T/same"; fail "mpirun -np $np lrr preprocess $args: exit $rc"
        fi
    done
done
# --memory-budget per rank: Cornell at 216 patches × 4 needs 3.9 MiB serially (F̄ 2.8 MiB):
# 3 MiB refuses the serial build and fits each of two ranks' share; the file is the
# unbudgeted serial one but for its timings. One thread: at k = 216 OpenBLAS's LU is
# threaded, and M's last bits follow its thread count (serially as well)
OMP_NUM_THREADS=1 "$LRR" preprocess cornell --patches 216 --levels 2 --hemicube 16 --seed 3 -o "$T/bud-serial.lrr" \
    >/dev/null 2>"$T/err" || { cat "$T/err"; fail "lrr preprocess (216 patches)"; }
"$LRR" preprocess cornell --patches 216 --levels 2 --hemicube 16 --seed 3 --memory-budget 3 \
    -o "$T/bud-refused.lrr" >/dev/null 2>"$T/bud.err"
brc=$?
mpi 2 env OMP_NUM_THREADS=1 "$LRR" preprocess cornell --patches 216 --levels 2 --hemicube 16 \
    --seed 3 --memory-budget 3 -o "$T/bud-mpi.lrr"
if [ "$brc" -eq 1 ] && grep -q "memory budget exceeded" "$T/bud.err" && [ "$rc" -eq 0 ] &&
    "$DIR/test_mpi_build" --same "$T/bud-mpi.lrr" "$T/bud-serial.lrr" >"$T/same"; then
    pass "--memory-budget 3: lrr preprocess refuses ($(grep -o 'needs [0-9.]* MiB' "$T/bud.err")), mpirun -np 2 writes the serial file (rank_fbar_mb $(value rank_fbar_mb))"
else
    cat "$T/bud.err" "$T/out" "$T/err" "$T/same"; fail "--memory-budget 3 across 2 ranks: exit $brc, $rc"
fi
mpi 2 "$LRR" preprocess cornell --backend opencl -o "$T/pre-cl.lrr"
if [ "$rc" -eq 2 ] && [ "$(grep -c "not available across MPI ranks" "$T/err")" -eq 1 ] &&
    [ ! -e "$T/pre-cl.lrr" ]; then
    pass "mpirun -np 2 lrr preprocess --backend opencl: exit 2, once: $(head -n 1 "$T/err")"
else
    cat "$T/out" "$T/err"; fail "mpirun -np 2 lrr preprocess --backend opencl: exit $rc"
fi
mpi 2 "$LRR" preprocess "$T/missing.obj" -o "$T/pre-missing.lrr"
if [ "$rc" -eq 1 ] && grep -q "missing.obj" "$T/err" && [ ! -e "$T/pre-missing.lrr" ]; then
    pass "mpirun -np 2 lrr preprocess of a missing scene: exit 1: $(head -n 1 "$T/err")"
else
    cat "$T/out" "$T/err"; fail "mpirun -np 2 lrr preprocess of a missing scene: exit $rc"
fi

# mpirun lrr reference --method path-trace: the serial CSV byte for byte (each path has its
# own random stream); the other methods are serial
"$LRR" reference cornell --method path-trace --samples 8 --csv "$T/ref-serial.csv" \
    >"$T/ref-serial.out" 2>"$T/err" || { cat "$T/err"; fail "lrr reference --method path-trace"; }
for np in 2 4; do
    mpi "$np" "$LRR" reference cornell --method path-trace --samples 8 --csv "$T/ref-mpi.csv"
    if [ "$rc" -eq 0 ] && [ "$(value ranks)" = "$np" ] && [ "$(grep -c '^n: ' "$T/out")" -eq 1 ] &&
        cmp -s "$T/ref-mpi.csv" "$T/ref-serial.csv" &&
        [ "$(value rel_std_error)" = "$(sed -n 's/^rel_std_error: //p' "$T/ref-serial.out")" ]; then
        pass "mpirun -np $np lrr reference --method path-trace: rank 0 alone prints, the serial CSV byte for byte"
    else
        cat "$T/out" "$T/err"; fail "mpirun -np $np lrr reference --method path-trace: exit $rc"
    fi
done
mpi 2 "$LRR" reference cornell --method jacobi
if [ "$rc" -eq 2 ] && [ "$(grep -c "not available across MPI ranks" "$T/err")" -eq 1 ]; then
    pass "mpirun -np 2 lrr reference --method jacobi: exit 2, once: $(head -n 1 "$T/err")"
else
    cat "$T/out" "$T/err"; fail "mpirun -np 2 lrr reference --method jacobi: exit $rc"
fi

# lrr-bench mpi: a smoke run (3 frames of the small box; the numbers are not judged)
BENCH=${LRR_BENCH_BIN:-./lrr-bench}
mpi 2 "$BENCH" mpi --frames 3 "$OP"
ok=1
for key in serial_ms mpi_ms allreduce_us allreduce_bytes rows_max fbar_bytes_max m_bytes; do
    [ -n "$(value "$key")" ] || ok=0
done
if [ "$rc" -eq 0 ] && [ "$ok" -eq 1 ] && [ "$(value ranks)" = 2 ] &&
    [ "$(value allreduce_bytes)" = $(((3 * $(value k) + 1) * 4)) ] &&
    awk -v v="$(value b_diff)" 'BEGIN { exit !(v ~ /^[0-9.eE+-]+$/ && v + 0 <= 1e-6) }'; then
    pass "mpirun -np 2 lrr-bench mpi: every key, allreduce of 3k + 1 floats, b_diff $(value b_diff)"
else
    cat "$T/out" "$T/err"; fail "mpirun -np 2 lrr-bench mpi: exit $rc"
fi

echo "mpi: $checks checks, $failures failed"
[ "$failures" -eq 0 ]
