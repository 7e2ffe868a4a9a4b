#!/bin/sh
# lrr reference: the four iterative and direct methods, convergence, --memory-budget.
. "$(dirname "$0")/harness.sh"

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


finish
