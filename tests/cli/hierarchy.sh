#!/bin/sh
# lrr preprocess --adaptive and --clusters: the hierarchies and their CSVs.
. "$(dirname "$0")/harness.sh"

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

finish
