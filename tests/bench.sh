#!/bin/sh
# Tests of the `lrr-bench` benchmark driver, run by `make check`.
# Environment: LRR_BENCH_BIN (the built lrr-bench; default ./lrr-bench), LRR_TEST_TMP (a
# writable directory). Prints one line per check; exits 0 when all pass, 1 otherwise.
set -u

BENCH=${LRR_BENCH_BIN:-./lrr-bench}
TMPROOT=${LRR_TEST_TMP:-${TMPDIR:-/tmp}}
if [ ! -x "$BENCH" ]; then
    echo "FAIL: LRR_BENCH_BIN='$BENCH' is not an executable"
    exit 1
fi
# lrr-bench's default scenes include the shipped OBJ files: a build without assimp
# (configure --without-assimp) cannot load them.
if [ -x "${LRR_BIN:-}" ] && ! "$LRR_BIN" --version | grep -q '^features:.* assimp\( \|$\)'; then
    echo "SKIP: lrr was built without assimp (lrr-bench's default scenes are OBJ files)"
    exit 77
fi
T=$(mktemp -d "$TMPROOT/bench.XXXXXX") || { echo "FAIL: cannot create a directory in $TMPROOT"; exit 1; }

failures=0
checks=0
pass() { checks=$((checks + 1)); echo "PASS: $1"; }
fail() { checks=$((checks + 1)); failures=$((failures + 1)); echo "FAIL: $1"; }

# run ARGS...: stdout in $T/out, stderr in $T/err, exit status in $rc.
run() {
    "$BENCH" "$@" >"$T/out" 2>"$T/err"
    rc=$?
}
show_err() { sed 's/^/    stderr: /' "$T/err" | tail -n 8; }

# ---------------------------------------------------------------- help
run --help
if [ "$rc" -eq 0 ] && grep -q 'table' "$T/out" && grep -q 'stress' "$T/out" &&
    grep -q 'hemicube' "$T/out"; then
    pass "lrr-bench --help lists table, stress, hemicube"
else
    fail "lrr-bench --help (exit $rc)"
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
        pass "lrr-bench $cmd --help mentions $*"
    else
        fail "lrr-bench $cmd --help (exit $rc), missing:$missing"
    fi
}
help_mentions table --scene --cells --hemicube --csv --plot --memory-budget --repeat 'MB = 10^6' \
    --backend opencl_ratio_to_ours
help_mentions stress --csv --hemicube --quick
help_mentions hemicube --csv --seeds rotation --rates --builds

# ---------------------------------------------------------------- command-line errors
run frobnicate
if [ "$rc" -eq 2 ] && grep -q frobnicate "$T/err"; then pass "unknown command: exit 2"; else fail "unknown command: exit $rc"; fi
run table --cells bogus
if [ "$rc" -eq 2 ] && grep -q -- '--cells' "$T/err"; then pass "--cells bogus: exit 2"; else fail "--cells bogus: exit $rc"; fi
run table --cells 100/10/3
if [ "$rc" -eq 2 ] && grep -q 'power of 4' "$T/err"; then pass "--cells with d = 3: exit 2"; else fail "--cells 100/10/3: exit $rc"; fi
run table --hemicube 7
if [ "$rc" -eq 2 ]; then pass "--hemicube 7: exit 2"; else fail "--hemicube 7: exit $rc"; fi
run table --repeat 0
if [ "$rc" -eq 2 ]; then pass "--repeat 0: exit 2"; else fail "--repeat 0: exit $rc"; fi
run stress --bogus
if [ "$rc" -eq 2 ] && grep -q -- '--bogus' "$T/err"; then pass "stress --bogus: exit 2"; else fail "stress --bogus: exit $rc"; fi

# ---------------------------------------------------------------- a tiny table
CSV="$T/table.csv"
PNG="$T/table.png"
start=$(date +%s)
run table --cells tiny --hemicube 32 --repeat 5 --csv "$CSV" --plot "$PNG"
secs=$(($(date +%s) - start))
if [ "$rc" -eq 0 ]; then
    pass "table --cells tiny (${secs} s)"
else
    fail "table --cells tiny: exit $rc"
    show_err
fi
header='n,k,d,mem_mb,mem_mb_paper,preprocess_s,rt_ms_ours,rt_ms_paper,rt_ms_3sgemv,floor_ms,rel_l2,max_rel'
if [ -f "$CSV" ] && head -n 1 "$CSV" | grep -q "^$header\(,\|\$\)"; then
    pass "table CSV header starts with the required columns"
else
    fail "table CSV header: '$(head -n 1 "$CSV" 2>/dev/null)'"
fi
[ -f "$CSV" ] || : >"$CSV"
rows=$(($(wc -l <"$CSV") - 1))
if [ "$rows" -eq 2 ]; then pass "table CSV has 2 rows"; else fail "table CSV has $rows rows, expected 2"; fi
# first tiny cell (d = 16): 0 < rel_l2 < 0.2; second (d = 1, exact model): rel_l2 < 1e-3
check=$(awk -F, '
    NR == 2 { if (!($11 ~ /^[0-9.eE+-]+$/ && $11 + 0 > 0 && $11 + 0 < 0.2)) print "d=" $3 " rel_l2 " $11;
              if (!($7 + 0 > 0 && $8 + 0 > 0 && $9 + 0 > 0)) print "times " $7 " " $8 " " $9;
              if ($4 + 0 <= 0 || $5 + 0 <= 0 || $6 + 0 <= 0) print "mem/preprocess " $4 " " $5 " " $6 }
    NR == 3 { if (!($11 ~ /^[0-9.eE+-]+$/ && $11 + 0 < 1e-3)) print "d=" $3 " rel_l2 " $11 }' "$CSV")
if [ -z "$check" ] && [ "$rows" -eq 2 ]; then
    pass "tiny cells: rel_l2 $(awk -F, 'NR==2{print $11}' "$CSV") (d = 16) and $(awk -F, 'NR==3{print $11}' "$CSV") (d = 1)"
else
    fail "tiny cells: $check"
fi
sig=$(od -An -tx1 -N8 "$PNG" 2>/dev/null | tr -d ' \n')
if [ "$sig" = 89504e470d0a1a0a ]; then
    pass "plot is a PNG ($(wc -c <"$PNG" | tr -d ' ') bytes)"
else
    fail "plot: signature '$sig'"
fi
if grep -q '^read_bandwidth_gbs: [0-9]' "$T/out" && grep -q '^cpu: ' "$T/out"; then
    pass "table prints the CPU and the bandwidth"
else
    fail "table does not print cpu/read_bandwidth_gbs"
fi
leftover=""
for f in "$T"/*tmp*; do [ -e "$f" ] && leftover="$leftover $f"; done
if [ -z "$leftover" ]; then pass "no temporary file left"; else fail "temporary files left:$leftover"; fi

# a budget too small for the n×n reference: n/a in the table, nan in the CSV
run table --cells 576/36/16 --hemicube 16 --repeat 2 --memory-budget 1 --csv "$T/nobudget.csv"
if [ "$rc" -eq 0 ] && grep -q 'n/a' "$T/out" && grep -q 'budget' "$T/out" &&
    [ "$(awk -F, 'NR==2{print $11 "," $12}' "$T/nobudget.csv")" = "nan,nan" ]; then
    pass "a reference over the budget: n/a with the reason, nan in the CSV"
else
    fail "--memory-budget 1: exit $rc, CSV '$(sed -n 2p "$T/nobudget.csv" 2>/dev/null)'"
    show_err
fi

# ---------------------------------------------------------------- stress
SCSV="$T/stress.csv"
start=$(date +%s)
# One thread: the check is about accuracy; Jacobi's thousands of short parallel sweeps crawl
# when a loaded machine preempts an OpenMP worker (seen: 56 s instead of 0.1 s on 2 cores).
OMP_NUM_THREADS=1
export OMP_NUM_THREADS
run stress --quick --csv "$SCSV"
secs=$(($(date +%s) - start))
if [ "$rc" -eq 0 ] && [ -f "$SCSV" ]; then
    pass "stress --quick (${secs} s, $(($(wc -l <"$SCSV") - 1)) rows)"
else
    fail "stress --quick: exit $rc"
    show_err
fi
[ -f "$SCSV" ] || : >"$SCSV"
# operator <= 1% for rho <= 0.99 and <= 5% at 0.999; reference solvers <= 1%; no NaN
bad=$(awk -F, '
    NR == 1 { next }
    {
        rho = $5 + 0; m = $6; err = $7
        if (err !~ /^[0-9.eE+-]+$/) { print $1 " rho " $5 " " m ": max_rel " err; next }
        lim = (m == "lrr" && rho > 0.995) ? 0.05 : 0.01
        if (err + 0 > lim) print $1 " rho " $5 " " m ": max_rel " err " > " lim
        if ($13 + 0 != 0) print $1 " rho " $5 " " m ": " $13 " non-finite values"
        if ($12 != "ok") print $1 " rho " $5 " " m ": status " $12
    }
    END { if (NR != 41) print "rows: " NR - 1 " (expected 40)" }' "$SCSV")
if [ -z "$bad" ]; then
    pass "stress: operator <= 1% (5% at rho 0.999), references <= 1%, all finite"
else
    fail "stress bounds:"
    echo "$bad" | sed 's/^/    /'
fi

# ---------------------------------------------------------------- hemicube
HCSV="$T/hemicube.csv"
run hemicube --quick --csv "$HCSV"
if [ "$rc" -eq 0 ] && [ -f "$HCSV" ] && [ "$(($(wc -l <"$HCSV") - 1))" -eq 4 ] &&
    awk -F, 'NR > 1 { for (i = 5; i <= 11; i++) if ($i !~ /^[-+0-9.eE]+$/) exit 1 }' "$HCSV" &&
    [ "$(awk -F, 'NR > 1 && $3 == "no"' "$HCSV" | wc -l)" -eq 2 ]; then
    pass "hemicube --quick: 4 rows of finite numbers, 2 without the rotation"
else
    fail "hemicube --quick: exit $rc"
    show_err
fi

HRCSV="$T/hemicube_rates.csv"
run hemicube --rates --quick --builds 2 --csv "$HRCSV"
# rows R 16 and 32 at one and at all threads, the issue's scene (n = 3456), min <= median <=
# max, and the rates n / seconds
bad=$(awk -F, 'NR > 1 { rows++; if ($3 != 3456 || $4 != 2 || !($5 > 0 && $5 <= $6 && $6 <= $7)) print "row " NR ": " $0;
                        r = $3 / $6; if (r / $8 > 1.0001 || r / $8 < 0.9999) print "rate row " NR }
               END { if (rows != 2 && rows != 4) print "rows: " rows }' "$HRCSV" 2>&1)
if [ "$rc" -eq 0 ] && [ -f "$HRCSV" ] && [ -z "$bad" ]; then
    pass "hemicube --rates --quick: R 16 and 32, n 3456, min <= median <= max, rate = n / median"
else
    fail "hemicube --rates --quick: exit $rc $bad"
    show_err
fi
run hemicube --builds 3
if [ "$rc" -eq 2 ]; then pass "hemicube --builds without --rates: exit 2"; else fail "hemicube --builds without --rates: exit $rc"; fi

# fbar: dense against sparse F̄ on a saved operator, two storages: the same B (summation
# order only), 0 < density <= strip density <= 1, positive times and floor ratios
LRRB=${LRR_BIN:-./lrr}
if [ -x "$LRRB" ] && "$LRRB" preprocess cornell --patches 54 --levels 1 --hemicube 32 \
    -o "$T/fbar.lrr" >/dev/null 2>&1; then
    run fbar --pairs 1 --storage f32,f16 --csv "$T/fbar.csv" "$T/fbar.lrr"
    bad=$(awk -F, 'NR == 1 { if ($23 != "b_diff") print "header: " $0; next }
                   { rows++; if (!($5 > 0 && $5 <= $6 && $6 <= 1) || !($23 <= 1e-5) ||
                                 !($10 > 0 && $11 > 0 && $14 > 0 && $17 > 0 && $20 > 0)) print "row " NR ": " $0 }
                   END { if (rows != 2) print "rows: " rows }' "$T/fbar.csv" 2>&1)
    if [ "$rc" -eq 0 ] && [ -z "$bad" ]; then
        pass "fbar --storage f32,f16: B sparse = B dense (b_diff <= 1e-5), densities in (0, 1]"
    else
        fail "fbar: exit $rc $bad"
        show_err
    fi
else
    fail "fbar: cannot build an operator with '$LRRB'"
fi
run fbar --storage f8 "$T/fbar.lrr"
if [ "$rc" -eq 2 ]; then pass "fbar --storage f8: exit 2"; else fail "fbar --storage f8: exit $rc"; fi
run fbar --strip-groups 3 "$T/fbar.lrr"
if [ "$rc" -eq 2 ]; then pass "fbar --strip-groups 3: exit 2"; else fail "fbar --strip-groups 3: exit $rc"; fi

# fbar --backend opencl: dense and sparse on the device, each B the CPU's (b_diff <= 1e-5),
# bytes, kernel times and read floors positive; skipped where no OpenCL is available
run fbar --backend opencl --storage f16 --strip-groups 1,4 --frames 3 --csv "$T/fbar_cl.csv" \
    "$T/fbar.lrr"
if [ "$rc" -ne 0 ] && grep -Eq 'not built into|no OpenCL platform' "$T/err"; then
    pass "fbar --backend opencl: skipped ($(head -n 1 "$T/err"))"
else
    bad=$(awk -F, 'NR == 1 { if ($10 != "b_diff") print "header: " $0; next }
                   { rows++; if (!($4 > 0 && $5 > 0 && $6 > 0 && $7 > 0) || !($10 <= 1e-5) ||
                                 $11 !~ /^opencl:/) print "row " NR ": " $0 }
                   END { if (rows != 3) print "rows: " rows }' "$T/fbar_cl.csv" 2>&1)
    if [ "$rc" -eq 0 ] && [ -z "$bad" ]; then
        pass "fbar --backend opencl: dense and 2 sparse rows, B the CPU's (b_diff <= 1e-5)"
    else
        fail "fbar --backend opencl: exit $rc $bad"
        show_err
    fi
fi

# raycast --rays: lrr's rays/s from centres and areas and Embree's on the same rays, all
# positive, the ray count n·3R² (Cornell: 36 triangles, R 16)
run raycast --rays cornell --hemicube 16
bad=$(awk -F, '/^scene,triangles/ { h = 1; next } h && NF == 10 { rows++; if ($2 != 36 || $3 != 16 || $5 != 36 * 3 * 256 || !($6 > 0 && $7 > 0 && $8 > 0)) print "row: " $0 }
               END { if (rows != 1) print "rows: " rows }' "$T/out" 2>&1)
if [ "$rc" -eq 0 ] && [ -z "$bad" ]; then
    pass "raycast --rays cornell: 36 × 3·16² rays, lrr and Embree rates > 0"
else
    fail "raycast --rays: exit $rc $bad"
    show_err
fi

# raycast --quick: T 36 and 144 at R 16, one and all threads, both rates > 0
run raycast --quick
bad=$(awk -F, '/^T,R,threads/ { h = 1; next } h && NF == 6 { rows++; if ($2 != 16 || !($4 > 0) || !($5 > 0)) print "row: " $0 }
               END { if (!h || (rows != 2 && rows != 4)) print "rows: " rows }' "$T/out" 2>&1)
if [ "$rc" -eq 0 ] && [ -z "$bad" ]; then
    pass "raycast --quick: T 36 and 144, raster and raycast rates > 0"
else
    fail "raycast --quick: exit $rc $bad"
    show_err
fi

# ---------------------------------------------------------------- realtime
run --help
if [ "$rc" -eq 0 ] && grep -q 'realtime' "$T/out"; then pass "lrr-bench --help lists realtime"; else fail "lrr-bench --help does not list realtime"; fi
help_mentions realtime --n --k --cells --scene --hemicube --repeat --csv 'Timing does' \
    'impl,storage,n,k,ms_median' --backend 'backend,kernel_ms,transfer_ms,device' \
    'Interleaved floor' ratio_pairs_median roofline_ms
run realtime --backend gpu
if [ "$rc" -eq 2 ] && grep -q -- '--backend' "$T/err"; then pass "realtime --backend gpu: exit 2"; else fail "realtime --backend gpu: exit $rc"; fi
run realtime --n 384
if [ "$rc" -eq 2 ] && grep -q -- '--k' "$T/err"; then pass "realtime --n without --k: exit 2"; else fail "realtime --n without --k: exit $rc"; fi
run realtime --n 384 --k 24 --cells tiny
if [ "$rc" -eq 2 ]; then pass "realtime --n/--k with --cells: exit 2"; else fail "realtime --n/--k with --cells: exit $rc"; fi

RCSV="$T/realtime.csv"
mkdir -p "$T/rt_tmp"
start=$(date +%s)
TMPDIR="$T/rt_tmp" "$BENCH" realtime --n 384 --k 24 --repeat 3 --hemicube 16 --csv "$RCSV" \
    >"$T/out" 2>"$T/err"
rc=$?
secs=$(($(date +%s) - start))
if [ "$rc" -eq 0 ] && [ -f "$RCSV" ]; then
    pass "realtime --n 384 --k 24 (${secs} s)"
else
    fail "realtime --n 384 --k 24: exit $rc"
    show_err
fi
[ -f "$RCSV" ] || : >"$RCSV"
rheader='impl,storage,n,k,ms_median,ms_min,ms_max,floor_ms,ratio_to_floor,ratio_to_paper,rel_l2_vs_f32'
if head -n 1 "$RCSV" | grep -q "^$rheader\(,\|\$\)"; then
    pass "realtime CSV header starts with the required columns"
else
    fail "realtime CSV header: '$(head -n 1 "$RCSV")'"
fi
missing=""
for impl in fused sgemv3 sgemm3 paper sparse incremental; do
    awk -F, -v i="$impl" 'NR > 1 && $1 == i { found = 1 } END { exit !found }' "$RCSV" ||
        missing="$missing $impl"
done
if [ -z "$missing" ]; then pass "realtime CSV has rows for all six implementations"; else fail "realtime CSV lacks:$missing"; fi
bad=$(awk -F, '
    NR == 1 { next }
    {
        for (j = 5; j <= 7; j++)
            if ($j !~ /^[0-9.eE+-]+$/ || !($j + 0 > 0)) print $1 " " $2 ": ms column " j " = " $j
        if ($1 == "fused" && $2 == "f16" && !($11 ~ /^[0-9.eE+-]+$/ && $11 + 0 < 1e-3))
            print "fused f16 rel_l2_vs_f32 " $11 " (want < 1e-3)"
        if ($1 == "fused" && $2 == "bf16" && !($11 ~ /^[0-9.eE+-]+$/ && $11 + 0 < 1e-2))
            print "fused bf16 rel_l2_vs_f32 " $11 " (want < 1e-2)"
        if ($1 == "sgemv3" && $11 != "nan") print "sgemv3 rel_l2_vs_f32 " $11 " (want nan)"
        if ($1 == "fused") f[$2] = 1
    }
    END { if (!f["f32"] || !f["f16"] || !f["bf16"]) print "fused rows for f32, f16 and bf16 missing" }' "$RCSV")
if [ -z "$bad" ] && [ -s "$RCSV" ]; then
    pass "realtime: positive finite times, f16 $(awk -F, '$1=="fused"&&$2=="f16"{print $11}' "$RCSV") < 1e-3, bf16 $(awk -F, '$1=="fused"&&$2=="bf16"{print $11}' "$RCSV") < 1e-2, sgemv3 nan"
else
    fail "realtime CSV values:"
    echo "$bad" | sed 's/^/    /'
fi
if grep -q '^target: fused f32' "$T/out" && grep -q '^batch: lrr_solve_batch 16 frames' "$T/out" &&
    grep -q '^omp_wait_policy: ' "$T/out" && grep -q '^openblas: ' "$T/out"; then
    pass "realtime prints the threading, the batch line and the targets"
else
    fail "realtime text output lacks target/batch/threading lines"
fi
if [ -z "$(ls -A "$T/rt_tmp")" ]; then pass "realtime left no temporary .lrr file"; else fail "realtime left in TMPDIR: $(ls -A "$T/rt_tmp")"; fi
if head -n 1 "$RCSV" | grep -q ',backend,kernel_ms,transfer_ms,device\(,\|$\)' &&
    awk -F, 'NR == 1 { for (j = 1; j <= NF; j++) c[$j] = j; next }
        $c["backend"] != "cpu" || $c["kernel_ms"] != "nan" || $c["transfer_ms"] != "nan" ||
        $c["device"] != "cpu" { bad = 1 } END { exit bad }' "$RCSV"; then
    pass "realtime --backend cpu: the backend columns, cpu,nan,nan,cpu on every row"
else
    fail "realtime --backend cpu: backend columns missing or wrong"
fi

# the interleaved floor: its columns appended, min <= median <= max, all finite and positive
# on the fused CPU rows, nan and 0 pairs on the others
if head -n 1 "$RCSV" | grep -q ',ratio_pairs_median,ratio_pairs_min,ratio_pairs_max,pairs,floor_pairs_ms,roofline_ms$'; then
    pass "realtime CSV ends with the interleaved columns"
else
    fail "realtime CSV lacks the interleaved columns: '$(head -n 1 "$RCSV")'"
fi
bad=$(awk -F, '
    NR == 1 { for (j = 1; j <= NF; j++) c[$j] = j; next }
    $c["backend"] == "cpu" && $1 == "fused" {
        md = $c["ratio_pairs_median"]; lo = $c["ratio_pairs_min"]; hi = $c["ratio_pairs_max"]
        fl = $c["floor_pairs_ms"]
        for (q = 1; q <= 4; q++) {
            v = q == 1 ? md : q == 2 ? lo : q == 3 ? hi : fl
            if (v !~ /^[0-9.eE+-]+$/ || !(v + 0 > 0)) print $2 ": not finite positive: " v
        }
        if (!(lo + 0 <= md + 0 && md + 0 <= hi + 0)) print $2 ": not min <= median <= max: " lo " " md " " hi
        if (!($c["pairs"] + 0 >= 7)) print $2 ": pairs " $c["pairs"]
        n++
        next
    }
    $c["pairs"] != "0" || $c["ratio_pairs_median"] != "nan" { print $1 " " $2 ": pairs " $c["pairs"] }
    END { if (n != 3) print "fused CPU rows: " n }' "$RCSV")
if [ -z "$bad" ] && [ -s "$RCSV" ]; then
    pass "realtime: interleaved ratios, min <= median <= max, finite and positive (f32 median $(awk -F, 'NR == 1 { for (j = 1; j <= NF; j++) c[$j] = j; next } $1 == "fused" && $2 == "f32" { print $c["ratio_pairs_median"] }' "$RCSV"))"
else
    fail "realtime interleaved ratios:"
    echo "$bad" | sed 's/^/    /'
fi
if grep -q '^interleaved: [0-9]* pairs' "$T/out" && grep -q '^fma_peak_gflops: ' "$T/out" &&
    grep -q '^target: fused f32 .*(interleaved median [0-9.]*)' "$T/out"; then
    pass "realtime prints the interleaved table, the FMA peak and the target on the median"
else
    fail "realtime text lacks the interleaved table, fma_peak_gflops or the median target"
fi
# the machine description: vendor, family and model from cpuid; the caches (sysfs, or cpuid
# where sysfs is silent) known on x86 Linux
case "$(uname -m)" in
x86_64 | i?86)
    if grep -q '^cpu: .*(\(Intel\|AMD\|[A-Za-z]*\) family [0-9][0-9]* model [0-9][0-9]*' "$T/out"; then
        pass "the machine line names the family and model ($(grep -m 1 '^cpu: ' "$T/out"))"
    else
        fail "the machine line lacks family and model: $(grep -m 1 '^cpu: ' "$T/out")"
    fi
    if grep -q '^caches: L' "$T/out" && ! grep -q '^caches: unknown' "$T/out"; then
        pass "the caches are known ($(grep -m 1 '^caches: ' "$T/out"))"
    else
        fail "caches: $(grep -m 1 '^caches: ' "$T/out")"
    fi
    ;;
esac

# realtime --backend opencl: skipped where no OpenCL device or platform is available
OCSV="$T/realtime_opencl.csv"
TMPDIR="$T/rt_tmp" "$BENCH" realtime --backend opencl --n 384 --k 24 --repeat 3 --hemicube 16 \
    --csv "$OCSV" >"$T/out" 2>"$T/err"
rc=$?
if [ "$rc" -ne 0 ] && grep -q -e 'not built into' -e 'no OpenCL platform' \
    -e 'no OpenCL GPU or CPU device' -e 'matches no OpenCL device' "$T/err"; then
    pass "realtime --backend opencl: skipped ($(grep -o -m 1 -e 'not built into[^(]*' \
        -e 'no OpenCL platform found' -e 'no OpenCL GPU or CPU device found' \
        -e 'matches no OpenCL device' "$T/err"))"
elif [ "$rc" -ne 0 ] || [ ! -s "$OCSV" ]; then
    fail "realtime --backend opencl: exit $rc"
    show_err
else
    bad=$(awk -F, '
        NR == 1 {
            for (j = 1; j <= NF; j++) c[$j] = j
            if (!c["backend"] || !c["kernel_ms"] || !c["transfer_ms"] || !c["device"])
                { print "header lacks backend,kernel_ms,transfer_ms,device"; exit }
            next
        }
        $c["backend"] == "opencl" {
            ocl[$2] = 1
            for (q = 0; q < 2; q++) {
                name = q ? "transfer_ms" : "kernel_ms"
                v = $c[name]
                if (v !~ /^[0-9.eE+-]+$/ || !(v + 0 > 0)) print $2 " opencl " name " = " v
            }
            if ($c["device"] !~ /^opencl:/) print $2 " opencl device = " $c["device"]
            next
        }
        $c["backend"] == "cpu" {
            if ($c["kernel_ms"] != "nan" || $c["transfer_ms"] != "nan")
                print $1 " " $2 " cpu row: kernel_ms " $c["kernel_ms"] ", transfer_ms " $c["transfer_ms"]
            cpu = 1
            next
        }
        { print "backend " $c["backend"] }
        END { if (!cpu || !ocl["f32"] || !ocl["f16"] || !ocl["bf16"]) print "cpu rows or opencl f32/f16/bf16 rows missing" }' "$OCSV")
    if [ -z "$bad" ] && grep -q '^opencl: ' "$T/out"; then
        pass "realtime --backend opencl: opencl rows with kernel_ms, transfer_ms > 0, cpu rows nan"
    else
        fail "realtime --backend opencl CSV:"
        echo "$bad" | sed 's/^/    /'
    fi
fi

# ---------------------------------------------------------------- probes
help_mentions probes --sources --normals --max-iterations --csv --plot --quick sh9
run probes --sources 0
if [ "$rc" -eq 2 ] && grep -q -- '--sources' "$T/err"; then pass "probes --sources 0: exit 2"; else fail "probes --sources 0: exit $rc"; fi
PROBE="${LRR_DATA_DIR:-./data}/probes/forest.hdr"
if [ ! -f "$PROBE" ]; then
    fail "probes: '$PROBE' is missing (LRR_DATA_DIR)"
else
    PCSV="$T/probes.csv"
    PPNG="$T/probes.png"
    run probes --quick --csv "$PCSV" --plot "$PPNG" "$PROBE"
    if [ "$rc" -eq 0 ] && head -n 1 "$PCSV" | grep -q '^probe,method,sources,mean_error_pct,max_error_pct,iterations,seconds'; then
        pass "probes --quick: CSV header"
    else
        fail "probes --quick (exit $rc): CSV header"
        show_err
    fi
    bad=$(awk -F, 'NR > 1 {
            rows[$2]++
            for (i = 4; i <= 7; i++)
                if ($i !~ /^[0-9.eE+-]+$/ || $i + 0 < 0) print "line " NR ": column " i " is " $i
            if ($2 == "median-cut") mc[$3] = $4
            if ($2 == "irradiance") ir[$3] = $4
        }
        END {
            if (rows["median-cut"] != 3 || rows["irradiance"] != 3 || rows["sh9"] != 1)
                print "rows: median-cut " rows["median-cut"] ", irradiance " rows["irradiance"] ", sh9 " rows["sh9"]
            for (n in ir)
                if (!(n in mc) || ir[n] + 0 > mc[n] + 0) print "N = " n ": irradiance " ir[n] " > median cut " mc[n]
        }' "$PCSV" 2>&1)
    if [ "$rc" -eq 0 ] && [ -z "$bad" ]; then
        pass "probes --quick: 3 median-cut, 3 irradiance, 1 sh9 rows, finite, irradiance <= median cut"
    else
        fail "probes --quick CSV:"
        echo "$bad" | sed 's/^/    /'
    fi
    if grep -q "reaches median cut's error at 2N" "$T/out"; then
        pass "probes --quick: the 2N line"
    else
        fail "probes --quick: no 'reaches median cut's error at 2N' line"
    fi
    sig=$(od -An -tx1 -N8 "$PPNG" 2>/dev/null | tr -d ' \n')
    if [ "$sig" = 89504e470d0a1a0a ]; then
        pass "probes plot is a PNG ($(wc -c <"$PPNG" | tr -d ' ') bytes)"
    else
        fail "probes --plot: '$PPNG' is not a PNG (signature '$sig')"
    fi
fi

# ---------------------------------------------------------------- adaptive
# The adaptive patch hierarchy (issue 7) against uniform subdivision at the same budget.
help_mentions adaptive --scene --subpatches --budgets --samples --hemicube --csv --plot \
    LRR_SPLIT_AREA LRR_SPLIT_VARIANCE selection_share 'adaptive rel_l2 / uniform'
run adaptive --budgets 0
if [ "$rc" -eq 2 ] && grep -q -- '--budgets' "$T/err"; then pass "adaptive --budgets 0: exit 2"; else fail "adaptive --budgets 0: exit $rc"; fi
run adaptive --budgets 12,x
if [ "$rc" -eq 2 ]; then pass "adaptive --budgets 12,x: exit 2"; else fail "adaptive --budgets 12,x: exit $rc"; fi
run adaptive --scene no-such-scene.obj
if [ "$rc" -eq 1 ] && grep -q 'no-such-scene' "$T/err"; then pass "adaptive: a missing scene fails at once"; else fail "adaptive --scene no-such-scene.obj: exit $rc"; fi

# The default scenes (cornell and DATA/office.obj), n about 300, three budgets per scene:
# 130 and 200 (above both scenes' triangle counts, 36 and 122) and 100000, taken as n (one
# patch per subpatch: the low-rank model is exact, so B matches the n×n reference).
ACSV="$T/adaptive.csv"
APNG="$T/adaptive.png"
start=$(date +%s)
run adaptive --subpatches 300 --budgets 130,200,100000 --hemicube 16 --repeat 3 --csv "$ACSV" \
    --plot "$APNG"
secs=$(($(date +%s) - start))
if [ "$rc" -eq 0 ] && [ -f "$ACSV" ] && grep -q '^scenes: cornell .*office\.obj$' "$T/out"; then
    pass "adaptive on cornell and office.obj (${secs} s)"
else
    fail "adaptive --subpatches 300: exit $rc"
    show_err
fi
[ -f "$ACSV" ] || : >"$ACSV"
aheader='scene,triangles,n,budget,split,k,d_min,d_max,rel_l2,max_rel,rel_l2_reflected,ratio,preprocess_s,build_s,selection_s,selection_share,rt_ms'
if head -n 1 "$ACSV" | grep -q "^$aheader\(,\|\$\)"; then
    pass "adaptive CSV header starts with the required columns"
else
    fail "adaptive CSV header: '$(head -n 1 "$ACSV")'"
fi
# per uniform/adaptive row: 0 <= rel_l2 < 1 (finite), k <= K and k >= K - 2 (a split adds 3
# patches), 1 <= d_min <= d_max, selection share in [0, 1], a positive frame time; at K = n:
# k = n, d_max = 1 and rel_l2 < 1e-4 (exact); the ratio column is adaptive / uniform.
bad=$(awk -F, '
    function num(v) { return v ~ /^[0-9.eE+-]+$/ }
    NR == 1 { next }
    $5 != "uniform" && $5 != "adaptive" {
        if ($5 !~ /^levels-[123]$/) print "line " NR ": split " $5
        else if (!(num($9) && $9 + 0 < 1)) print "line " NR ": " $5 " rel_l2 " $9
        next
    }
    {
        rows[$1 " " $5]++
        n = $3 + 0; K = $4 + 0; k = $6 + 0
        if (!(num($9) && $9 + 0 >= 0 && $9 + 0 < 1)) print $1 " K " $4 " " $5 ": rel_l2 " $9
        if (!num($10)) print $1 " K " $4 " " $5 ": max_rel " $10
        if (k > K || k + 2 < K) print $1 " K " $4 " " $5 ": k " k
        if (!($7 + 0 >= 1 && $7 + 0 <= $8 + 0 && $8 + 0 <= n)) print $1 " K " $4 " " $5 ": d " $7 ".." $8
        if (!(num($16) && $16 + 0 >= 0 && $16 + 0 <= 1)) print $1 " K " $4 " " $5 ": selection_share " $16
        if (!(num($17) && $17 + 0 > 0)) print $1 " K " $4 " " $5 ": rt_ms " $17
        if (K == n) {
            exact[$1]++
            if (k != n || $8 + 0 != 1 || !($9 + 0 < 1e-4)) print $1 " K = n " $5 ": k " k ", d_max " $8 ", rel_l2 " $9
        }
        if ($5 == "uniform") u[$1 " " K] = $9
        else if ((($1 " " K) in u) && u[$1 " " K] + 0 > 0) {
            want = ($9 + 0) / (u[$1 " " K] + 0)
            if ($12 + 0 < want * 0.999 || $12 + 0 > want * 1.001) print $1 " K " K ": ratio " $12 " != " want
        }
    }
    END {
        if (rows["cornell uniform"] != 3 || rows["cornell adaptive"] != 3 ||
            rows["office uniform"] != 3 || rows["office adaptive"] != 3)
            print "rows: cornell " rows["cornell uniform"] "+" rows["cornell adaptive"] ", office " rows["office uniform"] "+" rows["office adaptive"] " (want 3+3 each)"
        if (exact["cornell"] != 2 || exact["office"] != 2) print "K = n rows: " exact["cornell"] ", " exact["office"]
    }' "$ACSV")
if [ "$rc" -eq 0 ] && [ -z "$bad" ]; then
    pass "adaptive CSV: 3 budgets x 2 splits x 2 scenes, errors in [0,1), k within K-2..K, K = n exact"
else
    fail "adaptive CSV values:"
    echo "$bad" | sed 's/^/    /'
fi
if grep -q '^target: adaptive rel_l2 <= 0.5 x uniform' "$T/out" &&
    grep -q '^target: selection <= 20%' "$T/out" && grep -q '^target_ratio: [0-9]* of 4 cells' "$T/out" &&
    grep -q '^target_selection: [0-9]* of 6 builds' "$T/out"; then
    pass "adaptive prints both targets"
else
    fail "adaptive: target lines missing"
fi
sig=$(od -An -tx1 -N8 "$APNG" 2>/dev/null | tr -d ' \n')
if [ "$sig" = 89504e470d0a1a0a ]; then
    pass "adaptive plot is a PNG ($(wc -c <"$APNG" | tr -d ' ') bytes)"
else
    fail "adaptive --plot: signature '$sig'"
fi

# ---------------------------------------------------------------- scenes
# The end-to-end command of the real scenes, smoke-tested on the Cornell boxes (the real
# scenes take minutes): it runs, writes its CSV, Markdown and plot. No time thresholds.
help_mentions scenes --scene --scenes --data-dir --clusters --patches --split --hemicube \
    --samples --verify-samples --seed --threads --repeat --quick --csv --md --plot \
    ratio_f16_to_floor rel_l2 noise ratio_up ratio_side ratio_down rel_l2_subpatch \
    noise_subpatch verify_rel_l2 verify_noise verify_seconds
run scenes --split foo
if [ "$rc" -eq 2 ] && grep -q -- '--split' "$T/err"; then pass "scenes --split foo: exit 2"; else fail "scenes --split foo: exit $rc"; fi
run scenes --scenes no-such-scene
if [ "$rc" -eq 2 ] && grep -q 'no-such-scene' "$T/err"; then pass "scenes: an unknown scene: exit 2"; else fail "scenes --scenes no-such-scene: exit $rc"; fi
run scenes --scene cornell,no-such-scene
if [ "$rc" -eq 2 ] && grep -q -- '--scene: .no-such-scene' "$T/err"; then pass "scenes --scene: an unknown scene in a list: exit 2"; else fail "scenes --scene cornell,no-such-scene: exit $rc"; fi
# Two scenes, --scenes then --scene, in that order: cornell-closed for the outputs, cornell
# (256 paths a subpatch: the reference's noise about 2% over regions) for the judgement.
SCCSV="$T/scenes.csv"
run scenes --quick --scenes cornell-closed --scene cornell --samples 256 \
    --verify-samples 64 --repeat 5 --csv "$SCCSV" --md "$T/scenes.md" --plot "$T/scenes.png"
scheader='scene,cpu,threads,T,n,k,R,clustering_s,formfactor_s,smw_s,preprocess_s,peak_mib,ms_f32,ms_f32_iqr,ms_f16,ms_f16_iqr,floor_ms_f16,ratio_f16_to_floor,bandwidth_gbs,nk,rel_l2,noise,ratio_up,ratio_side,ratio_down,rel_l2_subpatch,noise_subpatch,verify_rel_l2,verify_noise,verify_seconds,samples'
if [ "$rc" -eq 0 ] && [ -f "$SCCSV" ] && head -n 1 "$SCCSV" | grep -q "^$scheader," &&
    grep -q '^scenes: cornell-closed cornell$' "$T/out" &&
    awk -F, 'NR == 2 && $1 == "cornell-closed" && $5 > 0 && $6 > 0 && $12 > 0 && $13 > 0 &&
        $15 > 0 && $21 ~ /^[0-9.eE+-]+$/ { ok = 1 } END { exit !ok }' "$SCCSV" &&
    grep -q '^Command: `lrr-bench scenes' "$T/scenes.md" && grep -q '^CPU: ' "$T/scenes.md" &&
    [ "$(od -An -tx1 -N8 "$T/scenes.png" 2>/dev/null | tr -d ' \n')" = 89504e470d0a1a0a ]; then
    pass "scenes --quick on cornell-closed and cornell: CSV rows in order, Markdown report, PNG plot"
else
    fail "scenes --quick on cornell-closed and cornell: exit $rc"
    show_err
fi
# The judgement on the Cornell box, by column name: errors small (an operator compared in its
# own subpatch order instead of the scene's gives rel_l2 > 4 and ratios of 1.1-1.8), the
# reference's noise above 0 and below the error bound, ratios near 1, the lamps left out
# (judged < n), the library's verification ran on the same subpatches with the 64 paths asked.
if [ "$rc" -eq 0 ] && awk -F, '
    NR == 1 { for (i = 1; i <= NF; i++) col[$i] = i; next }
    $1 == "cornell" {
        v = "rel_l2 noise ratio_up ratio_side ratio_down rel_l2_subpatch noise_subpatch " \
            "verify_rel_l2 verify_noise verify_seconds regions subpatches_judged n " \
            "verify_subpatches verify_samples"
        split(v, names, " ")
        for (i in names) { x = $(col[names[i]]); if (x !~ /^[0-9.eE+-]+$/) exit 1; c[names[i]] = x + 0 }
        ok = c["rel_l2"] > 0 && c["rel_l2"] <= 0.15 && c["noise"] > 0 && c["noise"] < 0.1 &&
            c["ratio_up"] >= 0.8 && c["ratio_up"] <= 1.2 && c["ratio_side"] >= 0.8 &&
            c["ratio_side"] <= 1.2 && c["ratio_down"] >= 0.8 && c["ratio_down"] <= 1.2 &&
            c["rel_l2_subpatch"] > 0 && c["rel_l2_subpatch"] <= 0.5 &&
            c["noise_subpatch"] > 0 && c["verify_rel_l2"] >= 0 && c["verify_rel_l2"] <= 0.15 &&
            c["verify_noise"] > 0 && c["verify_seconds"] > 0 && c["regions"] > 10 &&
            c["subpatches_judged"] > c["n"] / 2 && c["subpatches_judged"] < c["n"] &&
            c["verify_subpatches"] > c["n"] / 2 && c["verify_subpatches"] < c["n"] &&
            c["verify_samples"] == 64
    }
    END { exit !ok }' "$SCCSV" &&
    grep -q '^cornell: rel_l2 [0-9.]* noise [0-9.]* .*ratio_up [0-9.]* ratio_side [0-9.]* ratio_down [0-9.]* .*verify_rel_l2 [0-9.]*' "$T/out"; then
    pass "scenes on cornell: rel_l2 <= 15%, noise > 0, ratios within 0.8-1.2, lamps not judged, verify_rel_l2 beside"
else
    fail "scenes on cornell: the judgement's columns ($(grep '^cornell:' "$T/out"))"
    show_err
fi

# --operator judges a file instead of a build: the same operator (lrr preprocess with the
# bench's subdivision and options) gets the same judgement; one that another K subdivided is
# refused, naming --clusters.
LRR_TOOL=${LRR_BIN:-./lrr}
if [ -x "$LRR_TOOL" ]; then
    "$LRR_TOOL" preprocess cornell --clusters 200 --hemicube 16 -o "$T/op200.lrr" >/dev/null 2>&1
    run scenes --quick --scenes cornell --samples 64 --verify-samples 16 --repeat 3
    built=$(sed -n 's/^cornell: \(rel_l2 [0-9.]* noise [0-9.]*\).*/\1/p' "$T/out")
    run scenes --quick --scenes cornell --samples 64 --verify-samples 16 --repeat 3 \
        --operator "$T/op200.lrr"
    loaded=$(sed -n 's/^cornell: \(rel_l2 [0-9.]* noise [0-9.]*\).*/\1/p' "$T/out")
    if [ "$rc" -eq 0 ] && [ -n "$built" ] && [ "$built" = "$loaded" ]; then
        pass "scenes --operator: the file lrr preprocess wrote is judged as the bench's build ($loaded)"
    else
        fail "scenes --operator: exit $rc, '$loaded' against the build's '$built'"; show_err
    fi
    run scenes --quick --scenes cornell --clusters 100 --operator "$T/op200.lrr" --repeat 3
    if [ "$rc" -ne 0 ] && grep -q 'same --clusters' "$T/err"; then
        pass "scenes --operator of another subdivision: refused, naming --clusters"
    else
        fail "scenes --operator, other subdivision: exit $rc"; show_err
    fi
    run scenes --scenes cornell,cornell-closed --operator "$T/op200.lrr"
    if [ "$rc" -eq 2 ] && grep -q 'exactly one scene' "$T/err"; then
        pass "scenes --operator with two scenes: exit 2"
    else
        fail "scenes --operator with two scenes: exit $rc"; show_err
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
