#!/bin/sh
# The Python binding (python/lrr) against this build's liblrr: python3 -m unittest on
# python/tests (what each test asserts: python/tests/test_lrr.py). Skipped (77) only when no
# python3 with numpy is found (Debian: apt-get install python3 python3-numpy). LRR_PYTHON
# names an interpreter to try first.
set -u
top=${LRR_SRCDIR:-$(cd "$(dirname "$0")/.." && pwd)}
libdir=${LRR_LIBDIR:-$top/.libs}
so=$libdir/liblrr.so
if [ ! -f "$so" ]; then
    echo "python: no $so (built without shared libraries): skipped"
    exit 77
fi
# The first python3 on PATH that imports numpy: a python3 of its own (pyenv, a venv) may
# come first in PATH without numpy while the system's has it.
on_path=$(IFS=:; for d in $PATH; do [ -x "$d/python3" ] && echo "$d/python3"; done)
py=""
for cand in ${LRR_PYTHON:-} $on_path; do
    if "$cand" -c 'import numpy' >/dev/null 2>&1; then
        py=$cand
        break
    fi
done
if [ -z "$py" ]; then
    echo "python: no python3 with numpy found: skipped"
    exit 77
fi
# A sanitizer build's liblrr needs the ASan and UBSan runtimes loaded first (make check passes
# their paths in LRR_SANITIZE_PRELOAD); python's own allocations are not ours to leak-check.
preload=""
for f in ${LRR_SANITIZE_PRELOAD:-}; do
    [ -f "$f" ] && preload="$preload${preload:+ }$f"
done
if [ -n "$preload" ]; then
    LD_PRELOAD="$preload${LD_PRELOAD:+ $LD_PRELOAD}"
    ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0"
    export LD_PRELOAD ASAN_OPTIONS
    echo "python: sanitizer runtimes preloaded: $preload"
fi
tmp=$(mktemp -d "${LRR_TEST_TMP:-${TMPDIR:-/tmp}}/python.XXXXXX") || exit 1
trap 'rm -rf "$tmp"' EXIT
versions=$("$py" -c 'import sys, numpy; print(sys.version.split()[0], "numpy", numpy.__version__)')
echo "python: $py ($versions), $so"
LRR_LIBRARY=$so LRR_BUILDDIR=$(dirname "$libdir") LRR_SRCDIR=$top LRR_TEST_TMP=$tmp \
    PYTHONPATH=$top/python PYTHONDONTWRITEBYTECODE=1 \
    "$py" -m unittest discover -v -s "$top/python/tests" -t "$top/python/tests"
