#!/bin/sh
# lrr export: glTF binary and PLY meshes, the validators where installed, --light.
. "$(dirname "$0")/harness.sh"

small_lrr

# ---------------------------------------------------------------- export
run export "$LRRFILE" -o "$T/lit.glb"
sig=$(od -An -c -N4 "$T/lit.glb" 2>/dev/null | tr -d ' \n')
if [ "$rc" -eq 0 ] && [ "$sig" = glTF ] && [ "$(value vertices)" -gt 0 ] &&
    [ "$(value triangles)" -gt 0 ] && [ "$(value materials)" -gt 0 ] &&
    [ "$(value output)" = "$T/lit.glb" ]; then
    pass "export writes a .glb ($(value vertices) vertices, $(value triangles) triangles)"
else
    fail "export -o X.glb (exit $rc), signature '$sig'"
    show_err
fi
tris=$(value triangles)
glb_vertices=$(value vertices)
glb_materials=$(value materials)
run export "$LRRFILE" -o "$T/lit.ply" --subpatches --exposure auto
if [ "$rc" -eq 0 ] && [ "$(head -c 4 "$T/lit.ply")" = ply ] &&
    grep -aq "^element face $(value triangles)\$" "$T/lit.ply" && [ "$(value triangles)" -gt "$tris" ]; then
    pass "export --subpatches -o X.ply writes the subpatch mesh as PLY"
else
    fail "export --subpatches -o X.ply (exit $rc)"
    show_err
fi
# the Khronos validator, where it is installed (npm gltf-validator); skipped otherwise
VALIDATOR_JS=""
if command -v node >/dev/null 2>&1 && command -v npm >/dev/null 2>&1; then
    npm_root=$(npm root -g 2>/dev/null)
    [ -f "$npm_root/gltf-validator/package.json" ] && VALIDATOR_JS="$npm_root/gltf-validator"
fi
if [ -n "$VALIDATOR_JS" ]; then
    errors=$(node -e "require('$VALIDATOR_JS').validateBytes(new Uint8Array(require('fs')
        .readFileSync(process.argv[1]))).then(r => console.log(r.issues.numErrors))" "$T/lit.glb")
    if [ "$errors" = 0 ]; then pass "gltf-validator: 0 errors"; else fail "gltf-validator: '$errors' errors"; fi
else
    echo "SKIP: gltf-validator (npm) is not installed"
fi
# Blender's own glTF importer, where Blender is installed (Debian blender, python3-numpy)
if command -v blender >/dev/null 2>&1; then
    blender -b --python "${LRR_SRCDIR:-.}/tests/blender_import.py" -- "$T/lit.glb" > "$T/blender" 2>&1
    line=$(grep '^BLENDER_IMPORT' "$T/blender")
    if [ "$line" = "BLENDER_IMPORT meshes 1 vertices $glb_vertices triangles $tris materials $glb_materials" ] &&
        grep -q "^BLENDER_COLOR Col" "$T/blender"; then
        pass "Blender imports the .glb: $line, with its vertex colours"
    else
        fail "Blender import: '$line'"; grep -E 'Error|BLENDER' "$T/blender" | head -n 5
    fi
else
    echo "SKIP: blender is not installed"
fi
run export "$LRRFILE" -o "$T/lamp.glb" --light 'point pos=278,400,279 rgb=30000' \
    --no-scene-emission --exposure auto
if [ "$rc" -eq 0 ] && [ "$(value triangles)" = "$tris" ] &&
    awk -v x="$(value exposure)" 'BEGIN { exit !(x > 0) }'; then
    pass "export --light: the lit mesh of a moving light"
else
    fail "export --light (exit $rc)"; show_err
fi
run export "$LRRFILE" -o "$T/lamp.glb" --no-scene-emission
expect_rc 2 "export --no-scene-emission without --light or --probe is rejected"
run export "$LRRFILE" -o "$T/lit.obj"
expect_rc 2 "export -o X.obj without --format is a usage error"
run export "$LRRFILE" -o "$T/lit.glb" --format fbx
expect_rc 2 "export --format fbx is a usage error"
run export "$LRRFILE" -o "$T/lit.glb" --exposure 0
expect_rc 2 "export --exposure 0 is a usage error"
run export "$LRRFILE"
expect_rc 2 "export without -o is a usage error"


finish
