#!/bin/sh
# lrr probe and the probe lighting of solve and render (data/probes).
. "$(dirname "$0")/harness.sh"

small_lrr

# ---------------------------------------------------------------- light probes
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


finish
