#!/bin/sh
# Runs after every other test of make check (Makefile.am): fails when a test left a scratch
# file directly in tests/ of the source tree or the build tree instead of its own
# $LRR_TEST_TMP (tests/scratch-driver.sh). Build products (*.o, *.log, *.trs, the test
# programs) live in the build tree's tests/ legitimately, so only scratch patterns count:
# operator files, scenes, pictures, meshes, CSVs and NAME.PID / NAME_PID.EXT files, unless
# git tracks them. Also lists what failed tests kept in tests/tmp.
# Environment: LRR_SRCDIR, LRR_BIN (its directory is the build tree), LRR_TEST_TMP.
set -u
src=${LRR_SRCDIR:-.}
build=$(dirname "${LRR_BIN:-./lrr}")
tracked=""
if command -v git >/dev/null 2>&1 && git -C "$src" rev-parse --git-dir >/dev/null 2>&1; then
    tracked=$(git -C "$src" ls-files tests)
fi
stray=""
checked=""
for dir in "$src/tests" "$build/tests"; do
    [ -d "$dir" ] || continue
    d=$(cd "$dir" && pwd)
    case " $checked " in *" $d "*) continue ;; esac
    checked="$checked $d"
    for f in "$d"/* "$d"/.[!.]*; do
        [ -f "$f" ] || continue
        b=$(basename "$f")
        case $b in
            *.lrr | *.obj | *.mtl | *.png | *.exr | *.hdr | *.csv | *.glb | *.gltf | *.bin | \
                *.ply | *.json | *.tmp | *tmp.* | *.[0-9] | *.[0-9]*[0-9] | *_[0-9]*[0-9].*) ;;
            *) continue ;;
        esac
        # NAME.NNNN: only all digits after the last dot (a test's getpid suffix)
        case $b in *.[0-9]*) case ${b##*.} in *[!0-9]*) continue ;; esac ;; esac
        [ "$d" = "$(cd "$src/tests" && pwd)" ] && printf '%s\n' "$tracked" | grep -qx "tests/$b" &&
            continue
        stray="$stray $f"
    done
done
kept=""
tmp=$(dirname "${LRR_TEST_TMP:-$build/tests/tmp/scratch}")
for k in "$tmp"/*; do
    [ -d "$k" ] && [ "$k" != "${LRR_TEST_TMP:-}" ] && kept="$kept $(basename "$k")"
done
[ -z "$kept" ] || echo "note: failed tests kept their scratch files in $tmp:$kept"
if [ -n "$stray" ]; then
    echo "FAIL: scratch files outside tests/tmp (a test wrote beside the sources):"
    for f in $stray; do echo "    $f"; done
    exit 1
fi
echo "PASS: no scratch file directly in$checked"
