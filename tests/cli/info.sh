#!/bin/sh
# lrr info: the counts of a scene, a missing file, a textured glTF and a missing texture.
. "$(dirname "$0")/harness.sh"

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

# ---------------------------------------------------------------- textures
# The shipped textured glTF (data/textured/SOURCE.md): one texture, its white texels × the
# default factor 1 clamped below 1, counted by lrr info and warned about by lrr preprocess;
# a missing texture is a runtime error naming the file and the material.
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


# ---------------------------------------------------------------- not regular files
# A FIFO (or a device) named as a scene, an operator or a script is refused at once as "not a
# regular file" (lib/core/path.c), never waited on; timeout turns a regression into a failure.
mkfifo "$T/fifo.obj" "$T/fifo.lrr" "$T/fifo.txt" || fatal "mkfifo"
for c in "info $T/fifo.obj" "preprocess $T/fifo.obj -o $T/fifo-out.lrr" "solve $T/fifo.lrr" \
         "info /dev/zero" "animate $T/fifo.lrr --lights $T/fifo.txt -o $T/anim"; do
    # shellcheck disable=SC2086 # c is a command line
    timeout 60 "$LRR" $c >"$T/out" 2>"$T/err"
    rc=$?
    if [ "$rc" -eq 1 ] && grep -q 'not a regular file' "$T/err" && [ ! -e "$T/fifo-out.lrr" ]; then
        pass "lrr ${c%% *} of a FIFO or device: not a regular file"
    else
        fail "lrr $c: exit $rc"; show_err
    fi
done

finish
