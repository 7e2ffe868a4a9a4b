#!/bin/sh
# Assembles one OBJ scene from translated copies of others, for the large-scene row of
# `lrr-bench scenes` (issue 14: a scene of 250k triangles). Usage:
#   bench/assemble.sh OUT.obj FILE.obj DX DY DZ [FILE.obj DX DY DZ ...]
# Each FILE's vertices are moved by (DX, DY, DZ); its faces keep their materials (the .mtl
# files are concatenated into OUT.mtl: material names must not clash with different
# values). Only 'v', 'f', 'usemtl' and comments are read: the scenes in data/scenes have
# nothing else. Writes OUT atomically (a temporary file renamed at the end).
set -eu
[ $# -ge 5 ] && [ $((($# - 1) % 4)) -eq 0 ] || {
    echo "usage: $0 OUT.obj FILE.obj DX DY DZ [FILE.obj DX DY DZ ...]" >&2
    exit 2
}
out=$1
shift
base=${out%.obj}
tmp=$(mktemp "$out.tmp.XXXXXX")
mtmp=$(mktemp "$base.mtl.tmp.XXXXXX")
trap 'rm -f "$tmp" "$mtmp"' EXIT
echo "# assembled by bench/assemble.sh from: $*" > "$tmp"
echo "mtllib $(basename "$base").mtl" >> "$tmp"
offset=0
while [ $# -gt 0 ]; do
    f=$1 dx=$2 dy=$3 dz=$4
    shift 4
    [ -r "$f" ] || { echo "$0: cannot read $f" >&2; exit 1; }
    mtl="$(dirname "$f")/$(sed -n 's/^mtllib //p' "$f" | head -n 1)"
    [ -r "$mtl" ] && cat "$mtl" >> "$mtmp"
    # faces 'f a b c' with 1-based (or a/b/c) indices: shifted by the vertices before
    awk -v dx="$dx" -v dy="$dy" -v dz="$dz" -v off="$offset" -v src="$f" '
        $1 == "v" { printf "v %.9g %.9g %.9g\n", $2 + dx, $3 + dy, $4 + dz; next }
        $1 == "f" { printf "f"; for (i = 2; i <= NF; i++) { split($i, p, "/");
                    if (p[1] < 0) { print "negative index in " src > "/dev/stderr"; exit 1 }
                    printf " %d", p[1] + off }; printf "\n"; next }
        $1 == "usemtl" { print; next }' "$f" >> "$tmp"
    offset=$((offset + $(grep -c '^v ' "$f")))
done
chmod 644 "$tmp" "$mtmp"
mv "$mtmp" "$base.mtl"
mv "$tmp" "$out"
trap - EXIT
