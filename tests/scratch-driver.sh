#!/bin/sh
# The test driver of make check (Makefile.am: LOG_DRIVER), around automake's test-driver:
# each test gets its own empty scratch directory, $LRR_TEST_TMP/NAME (the build tree's
# tests/tmp: never the source tree, VPATH builds included), exported as LRR_TEST_TMP; the
# directory is removed once the test passed or skipped and kept, for its files, when it
# failed.
# Usage: scratch-driver.sh DRIVER... --test-name NAME ... --trs-file FILE ... -- TEST ARGS
# (DRIVER: the command of the real driver, e.g. "/bin/sh build-aux/test-driver").
set -u
name="" trs=""
prev=""
for a in "$@"; do
    case $prev in
        --test-name) name=$a ;;
        --trs-file) trs=$a ;;
    esac
    [ "$a" = -- ] && break
    prev=$a
done
root=${LRR_TEST_TMP:-tests/tmp}
# tests/cli/usage.sh -> cli-usage; tests/core/test_error -> core-test_error
dir=$(echo "${name#tests/}" | sed -e 's/\.sh$//' -e 's|/|-|g')
scratch="$root/${dir:-unnamed}"
rm -rf "$scratch"
mkdir -p "$scratch" || { echo "scratch-driver.sh: cannot create $scratch" >&2; exit 99; }
LRR_TEST_TMP=$scratch
export LRR_TEST_TMP
"$@"
status=$?
case "$(sed -n 's/^:test-result: //p' "$trs" 2>/dev/null | head -n 1)" in
    PASS | SKIP | XFAIL) rm -rf "$scratch" ;;
    *) echo "scratch-driver.sh: $name failed; its scratch files are kept in $scratch" >&2 ;;
esac
exit $status
