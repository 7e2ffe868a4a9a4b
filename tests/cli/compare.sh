#!/bin/sh
# lrr compare: identical and scaled CSVs, the methods' agreement, d = 1 against the direct
# solve, the path tracer, damaged and mismatched CSVs.
. "$(dirname "$0")/harness.sh"

SMALL="cornell --patches 24 --levels 1 --hemicube 32"
# the four methods' CSVs on the same tiny scene (tests/cli/reference.sh checks them)
for m in jacobi gauss-seidel southwell direct; do
    # shellcheck disable=SC2086 # SMALL is a list of arguments
    run reference $SMALL --method "$m" --tol 1e-9 --csv "$T/ref-$m.csv"
    [ "$rc" -eq 0 ] && [ -s "$T/ref-$m.csv" ] || { show_err; fatal "reference --method $m: exit $rc"; }
done

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


finish
