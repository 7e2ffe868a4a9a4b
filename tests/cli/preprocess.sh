#!/bin/sh
# lrr preprocess: the operator file, the light-leak indicator, --receiver, --verify, the
# automatic clusters, --memory-budget, --backend, --storage, --formfactor, the condition warning.
. "$(dirname "$0")/harness.sh"

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

# --fbar-file: the same operator stored as strips (version 5) and dense (version 1) gives the
# same radiosity to the last digit; a bad value is a usage error
ok=1
for f in sparse dense; do
    run preprocess cornell -o "$T/fbar-$f.lrr" --patches 30 --levels 1 --hemicube 32 --threads 2 \
        --fbar-file "$f"
    [ "$rc" -eq 0 ] || ok=0
    run info "$T/fbar-$f.lrr"
    eval "version_$f=\$(value file_version) bytes_$f=\$(value file_bytes)"
    run solve "$T/fbar-$f.lrr" --csv "$T/fbar-$f.csv" --repeat 1 --fbar dense
    [ "$rc" -eq 0 ] || ok=0
done
if [ "$ok" = 1 ] && [ "$version_sparse" = 5 ] && [ "$version_dense" = 1 ] &&
    [ "$bytes_dense" = "$(wc -c <"$T/fbar-dense.lrr" | tr -d ' ')" ] &&
    cmp -s "$T/fbar-sparse.csv" "$T/fbar-dense.csv"; then
    pass "--fbar-file sparse (version 5, $bytes_sparse bytes) and dense (version 1, $bytes_dense bytes): identical B"
else
    fail "--fbar-file: versions '$version_sparse' '$version_dense', B identical: $(cmp "$T/fbar-sparse.csv" "$T/fbar-dense.csv" 2>&1)"
    show_err
fi
run preprocess cornell -o "$T/fbar-bad.lrr" --fbar-file strips
if [ "$rc" -eq 2 ] && grep -q "fbar-file: 'strips' is not one of auto, dense, sparse" "$T/err"; then
    pass "--fbar-file strips: usage error"
else
    fail "--fbar-file strips: exit $rc"; show_err
fi

# the light-leak indicator: the share of hemicube pixels seeing back faces, and the worst
# triangles. A cube with all faces outward: no receiver sees a back. The same cube with face
# 5 flipped inwards: that face sees only backs (share 1), 1 of 12 triangles → 1/12.
# cornell-closed is not 0: the floor under the closed blocks and the ceiling over the
# one-sided light (0.05 mm under it) see back faces; they are hidden and receive nothing.
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


finish
