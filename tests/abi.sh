#!/bin/sh
# The exported ABI: the LRR_API functions of include/lrr.h, the names lib/liblrr.map exports
# and the dynamic symbols liblrr.so defines (nm -D) must be the same set, so nothing is
# exported by accident (a helper, a C++ template instance) and nothing declared is missing.
# Each difference is printed with the side it is on.
set -u
top=${LRR_SRCDIR:-$(cd "$(dirname "$0")/.." && pwd)}
libdir=${LRR_LIBDIR:-$top/.libs}
so=$libdir/liblrr.so
if [ ! -f "$so" ]; then
    echo "abi: no $so (built without shared libraries): skipped"
    exit 77
fi
command -v nm >/dev/null 2>&1 || { echo "abi: nm not found: skipped"; exit 77; }
tmp=$(mktemp -d) || exit 1
trap 'rm -rf "$tmp"' EXIT
# function names after LRR_API (declarations may wrap after the name's parenthesis)
sed -n 's/^LRR_API[^(]*[^a-z0-9_]\(lrr_[a-z0-9_]*\)(.*/\1/p' "$top/include/lrr.h" | sort -u > "$tmp/header"
# the public names (lrr_x); the private ones (lrr__x, node LRR_PRIVATE_N, for liblrr_mpi)
# are checked apart below, against the LRR__PRIVATE_API declarations of the private headers (lib/*/rows.h, build.h, file/stream.h)
sed -n '/global:/,/local:/s/^[[:space:]]*\(lrr_[a-z0-9_]*\);.*/\1/p' "$top/lib/liblrr.map" | sort -u > "$tmp/all"
grep -v '^lrr__' "$tmp/all" > "$tmp/map"
grep '^lrr__' "$tmp/all" > "$tmp/private_map"
sed -n 's/^LRR__PRIVATE_API[^(]*[^a-z0-9_]\(lrr__[a-z0-9_]*\)(.*/\1/p' "$top/lib/solve/rows.h" \
    "$top/lib/operator/build.h" "$top/lib/reference/rows.h" "$top/lib/verify/rows.h" \
    "$top/lib/file/stream.h" |
    sort -u > "$tmp/private_header"
nm -D --defined-only "$so" | awk '{print $3}' | sed 's/@.*//' | grep -v '^LRR_' | sort -u > "$tmp/all_so"
grep -v '^lrr__' "$tmp/all_so" > "$tmp/so"
grep '^lrr__' "$tmp/all_so" > "$tmp/private_so"
# every private name in the node LRR_PRIVATE_N, not in a public one
nm -D --defined-only "$so" | awk '{print $3}' | grep '^lrr__' | grep -v '@@LRR_PRIVATE_[0-9]*$' |
    while read -r name; do echo "abi: $name is not versioned LRR_PRIVATE_N"; done > "$tmp/private_node"
fail=0
n=$(wc -l < "$tmp/header")
[ "$n" -ge 50 ] || { echo "abi: only $n LRR_API functions found in include/lrr.h"; fail=1; }
report() { # report A B what
    comm -23 "$tmp/$1" "$tmp/$2" | while read -r name; do echo "abi: $3: $name"; done
    [ -z "$(comm -23 "$tmp/$1" "$tmp/$2")" ]
}
report header map "declared LRR_API in lrr.h but not in lib/liblrr.map" || fail=1
report map header "in lib/liblrr.map but not declared LRR_API in lrr.h" || fail=1
report map so "in lib/liblrr.map but not defined by liblrr.so" || fail=1
report so map "exported by liblrr.so but not in lib/liblrr.map" || fail=1
report private_header private_map "declared LRR__PRIVATE_API in a private header but not in lib/liblrr.map" || fail=1
report private_map private_header "private in lib/liblrr.map but not declared in a private header" || fail=1
report private_map private_so "private in lib/liblrr.map but not defined by liblrr.so" || fail=1
report private_so private_map "exported by liblrr.so (lrr__) but not in lib/liblrr.map" || fail=1
if [ -s "$tmp/private_node" ]; then cat "$tmp/private_node"; fail=1; fi
# Only lrr_* (and the version nodes LRR_1, LRR_1.1, ...) may be defined, whatever the map
# says: a C++ template instance or a helper of the dependencies must stay local.
others=$(nm -D --defined-only "$so" | awk '{print $3}' | sed 's/@.*//' |
         grep -v -e '^lrr_' -e '^LRR_[0-9.]*$' -e '^LRR_PRIVATE_[0-9]*$' | sort -u)
if [ -n "$others" ]; then
    echo "abi: $(echo "$others" | wc -l) exported symbols are not lrr_*:"
    echo "$others" | sed 's/^/abi:   /'
    fail=1
fi
if ! nm -D --defined-only "$so" | grep -q ' lrr_solve@@LRR_1$'; then
    echo "abi: lrr_solve is not versioned LRR_1 (is the version script applied?)"
    fail=1
fi
[ "$fail" -eq 0 ] && echo "abi: $n functions, header = lib/liblrr.map = nm -D $so;" \
    "$(wc -l < "$tmp/private_map") private (lib/solve/rows.h, LRR_PRIVATE_N)"
exit "$fail"
