#!/bin/sh
# lrr --help, --version and the command-line errors every command shares (exit 2).
. "$(dirname "$0")/harness.sh"

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


finish
