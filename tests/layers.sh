#!/bin/sh
# The layering of lib/ (docs/ARCHITECTURE.md): a stage includes only its own header and
# those of the stages it may call, so the pipeline reads one way; the numerics (operator,
# solve) include no file-format, import or CLI library. Fails naming the file and the
# include that breaks the rule.
set -u
top=${LRR_SRCDIR:-$(cd "$(dirname "$0")/.." && pwd)}
fail=0
allowed() {
    case $1 in
        core) echo "core" ;;
        scene) echo "core scene" ;;
        hierarchy) echo "core scene hierarchy" ;;
        formfactor) echo "core scene formfactor" ;;
        operator) echo "core scene hierarchy formfactor operator" ;;
        solve) echo "core scene operator solve" ;;
        file) echo "core scene operator file" ;;
        reference) echo "core scene formfactor reference" ;;
        verify) echo "core scene operator reference verify" ;;
        light) echo "core scene operator light" ;;
        probe) echo "core scene operator light probe" ;;
        output) echo "core scene operator output" ;;
        mpi) echo "solve operator reference verify file mpi" ;;
        *) echo "" ;;
    esac
}
stages=0
for dir in "$top"/lib/*/; do
    stage=$(basename "$dir")
    ok=$(allowed "$stage")
    if [ -z "$ok" ]; then
        echo "lib/$stage: a folder the layering does not know (add it to tests/layers.sh and docs/ARCHITECTURE.md)"
        fail=1
        continue
    fi
    stages=$((stages + 1))
    for f in "$dir"*.c "$dir"*.cpp "$dir"*.h "$dir"*.cl; do
        [ -f "$f" ] || continue
        rel=lib/$stage/$(basename "$f")
        for inc in $(sed -n 's/^[[:space:]]*#[[:space:]]*include[[:space:]]*"\([a-z_]*\)\/.*/\1/p' "$f"); do
            case " $ok " in
                *" $inc "*) ;;
                *) echo "$rel includes $inc/: stage $stage may include only: $ok"; fail=1 ;;
            esac
        done
        if grep -q '^[[:space:]]*#[[:space:]]*include[[:space:]]*"internal.h"' "$f"; then
            echo "$rel includes \"internal.h\": name the stage header (core/internal.h, scene/scene.h, ...)"
            fail=1
        fi
        case $stage in operator|solve)
            if grep -En '^[[:space:]]*#[[:space:]]*include[[:space:]]*<(assimp|stb_|Imf|openexr|CGAL|embree)' "$f"; then
                echo "$rel: the numerics include a file-format or geometry library"
                fail=1
            fi ;;
        esac
    done
done
# Everything the code cites is in the repository: docs/NAME.md files that exist, no notes
# kept outside it.
for f in $(find "$top/lib" "$top/include" "$top/tools" "$top/bench" "$top/tests" \
               \( -name '*.[ch]' -o -name '*.cpp' -o -name '*.cl' -o -name '*.sh' \) -print); do
    rel=${f#"$top"/}
    [ "$rel" = tests/layers.sh ] && continue
    if grep -n 'DESIGN\.md\|STYLE\.md\|shared/reference\|\.\./shared' "$f"; then
        echo "$rel cites a file outside the repository (the formulas live in docs/METHOD.md)"
        fail=1
    fi
    for doc in $(grep -o 'docs/[A-Za-z_]*\.md' "$f" | sort -u); do
        [ -f "$top/$doc" ] || { echo "$rel cites $doc, which does not exist"; fail=1; }
    done
done
[ "$stages" -ge 10 ] || { echo "found only $stages stage folders under $top/lib"; fail=1; }
[ "$fail" -eq 0 ] && echo "layers: $stages stages, every include allowed, every citation in the repository"
exit "$fail"
