#!/bin/sh
# lrr solve: the CSV, linearity in the emission, the paths, kernels and backends, 16-bit
# storage, --formfactor's operators, damaged input.
. "$(dirname "$0")/harness.sh"

small_lrr

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

# F̄ read dense or sparse: the same radiosity (summation order only), and what each read is
# reported (the Cornell box's F̄ is too dense for auto to choose sparse)
for f in dense sparse auto; do
    run solve "$LRRFILE" --fbar "$f" --csv "$T/fbar-$f.csv" --repeat 1
    eval "fbar_$f=\$(value fbar) bytes_$f=\$(value fbar_bytes) density_$f=\$(value fbar_density)"
done
run compare "$T/fbar-sparse.csv" "$T/fbar-dense.csv"
mx=$(value max_rel)
if [ "$rc" -eq 0 ] && [ "$fbar_dense" = dense ] && [ "$fbar_sparse" = sparse ] &&
    [ "$fbar_auto" = dense ] && [ "$density_sparse" = "$density_dense" ] &&
    awk -v e="$mx" -v d="$density_dense" 'BEGIN { exit !(e <= 1e-6 && d > 0 && d < 1) }'; then
    pass "solve --fbar sparse = dense (max_rel $mx; density $density_dense, bytes $bytes_sparse of $bytes_dense; auto: $fbar_auto)"
else
    fail "solve --fbar: max_rel '$mx', fbar '$fbar_dense' '$fbar_sparse' '$fbar_auto', density '$density_dense' '$density_sparse' (exit $rc)"
    show_err
fi
run info "$LRRFILE"
if [ "$rc" -eq 0 ] && [ "$(value fbar)" = dense ] && [ "$(value fbar_bytes)" = "$bytes_dense" ] &&
    [ "$(value fbar_density)" = "$density_dense" ]; then
    pass "info FILE.lrr: fbar dense, fbar_bytes $bytes_dense, fbar_density $density_dense as solve says"
else
    fail "info FILE.lrr: fbar '$(value fbar)' bytes '$(value fbar_bytes)' density '$(value fbar_density)'"
fi
run solve "$LRRFILE" --fbar csr
expect_rc 2 "solve --fbar csr is a usage error"
# sparse on an OpenCL device: the CPU's B, the same density and strip bytes reported
run solve "$LRRFILE" --fbar sparse --backend opencl --csv "$T/fbar-cl.csv" --repeat 1
if [ "$rc" -ne 0 ] && grep -Eq 'not built into|no OpenCL platform' "$T/err"; then
    pass "solve --fbar sparse --backend opencl: skipped, no OpenCL here ($(head -n 1 "$T/err"))"
else
    cl_fbar=$(value fbar) cl_density=$(value fbar_density)
    run compare "$T/fbar-cl.csv" "$T/fbar-dense.csv"
    mx=$(value max_rel)
    if [ "$rc" -eq 0 ] && [ "$cl_fbar" = sparse ] && [ "$cl_density" = "$density_dense" ] &&
        awk -v e="$mx" 'BEGIN { exit !(e <= 1e-5) }'; then
        pass "solve --fbar sparse --backend opencl = CPU dense (max_rel $mx, density $cl_density)"
    else
        fail "solve --fbar sparse --backend opencl: fbar '$cl_fbar' density '$cl_density' max_rel '$mx' (exit $rc)"
        show_err
    fi
fi

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
# M read as M - I in binary16 by default with 16-bit F̄ (half of M's bytes), --m f32 forces
# float; both give the same radiosity to binary16's rounding.
run solve "$T/f16.lrr" --csv "$T/m-auto.csv" --repeat 1
m_auto=$(value m) bytes_auto=$(value m_bytes)
run solve "$T/f16.lrr" --m f32 --csv "$T/m-f32.csv" --repeat 1
m_f32=$(value m) bytes_f32=$(value m_bytes)
run compare "$T/m-auto.csv" "$T/m-f32.csv"
mx=$(value max_rel)
if [ "$rc" -eq 0 ] && [ "$m_auto" = f16 ] && [ "$m_f32" = f32 ] &&
    awk -v e="$mx" -v a="$bytes_auto" -v b="$bytes_f32" \
        'BEGIN { exit !(e <= 1e-3 && 2 * a > b && 2 * a < 1.1 * b) }'; then
    pass "solve --m: auto f16 ($bytes_auto bytes) = f32 ($bytes_f32 bytes) to max_rel $mx"
else
    fail "solve --m: m '$m_auto' '$m_f32', bytes '$bytes_auto' '$bytes_f32', max_rel '$mx' (exit $rc)"
    show_err
fi
run solve "$LRRFILE" --m bf16
expect_rc 2 "solve --m bf16 is a usage error"
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


# ---------------------------------------------------------------- LRR_SIMD
# One set of names for the form factors and the solver (lib/core/cpu.c); anything else is
# an error naming them, and preprocess writes no file then.
names='not one of c, avx2, avx2+prefetch, avx512, avx512+prefetch'
LRR_SIMD=bogus run preprocess cornell --patches 30 --levels 1 --hemicube 16 -o "$T/simd.lrr"
if [ "$rc" -eq 1 ] && grep -q "LRR_SIMD=bogus: $names" "$T/err" && [ ! -e "$T/simd.lrr" ]; then
    pass "LRR_SIMD=bogus: preprocess refuses it, naming the valid values"
else
    fail "LRR_SIMD=bogus preprocess: exit $rc"; show_err
fi
LRR_SIMD=bogus run solve "$LRRFILE" --repeat 1
if [ "$rc" -eq 1 ] && grep -q "LRR_SIMD=bogus: $names" "$T/err"; then
    pass "LRR_SIMD=bogus: solve refuses it, naming the valid values"
else
    fail "LRR_SIMD=bogus solve: exit $rc"; show_err
fi
# the solver's "+prefetch" names are the form factors' plain levels; c gives the same file
LRR_SIMD=avx2+prefetch run preprocess cornell --patches 30 --levels 1 --hemicube 16 -o "$T/simd.lrr"
if [ "$rc" -eq 0 ] || grep -q 'LRR_SIMD=avx2+prefetch: this CPU lacks the instructions' "$T/err"; then
    pass "LRR_SIMD=avx2+prefetch: preprocess takes the solver's names (exit $rc)"
else
    fail "LRR_SIMD=avx2+prefetch preprocess: exit $rc"; show_err
fi

finish
