# The harness of the `lrr` command-line tests (tests/cli/*.sh, one script per command),
# sourced by each: `. "$(dirname "$0")/harness.sh"`, checks, then `finish`.
# Environment (make check sets it): LRR_BIN (the built lrr; default ./lrr), LRR_TEST_TMP (a
# writable directory: the build tree's tests/tmp/NAME, tests/scratch-driver.sh), LRR_SRCDIR,
# LRR_DATA_DIR; LRR_VALGRIND=1 (make check-valgrind) runs every lrr invocation under
# valgrind memcheck.
# Each check prints one PASS or FAIL line; finish prints the count and exits 0 when all
# passed, 1 otherwise (the scratch directory $T is kept then, and named).
set -u

LRR=${LRR_BIN:-./lrr}
TMPROOT=${LRR_TEST_TMP:-${TMPDIR:-/tmp}}
SRCDIR=${LRR_SRCDIR:-.}
DATA=${LRR_DATA_DIR:-data}
TDATA=$SRCDIR/tests/data
TEST_NAME=$(basename "$0" .sh)
if [ ! -x "$LRR" ]; then
    echo "FAIL: LRR_BIN='$LRR' is not an executable"
    exit 1
fi
# Most checks read scene files, .exr probes and pictures or run lrr check: a build without
# one of those (configure --without-X) skips them all; tests/features.sh checks its errors.
for feature in assimp cgal openexr; do
    case " $("$LRR" --version | sed -n 's/^features://p') " in
        *" $feature "*) ;;
        *) echo "SKIP: lrr was built without $feature (tests/features.sh covers that build)"; exit 77 ;;
    esac
done
mkdir -p "$TMPROOT" 2>/dev/null
T=$(mktemp -d "$TMPROOT/cli-$TEST_NAME.XXXXXX") ||
    { echo "FAIL: cannot create a directory in $TMPROOT"; exit 1; }

failures=0
checks=0
pass() { checks=$((checks + 1)); echo "PASS: $1"; }
fail() { checks=$((checks + 1)); failures=$((failures + 1)); echo "FAIL: $1"; }
# fatal MESSAGE: a fixture the checks need could not be made; stops the script (files kept).
fatal() { echo "FAIL: $1 (fixture; files kept in $T)"; exit 1; }

# LRR_VALGRIND=1 (make check-valgrind, .ci/run): every lrr invocation runs under valgrind
# memcheck. A memory error or a definite or indirect leak makes that invocation exit 99,
# which fails its check, and the last check of each script lists every invocation whose
# valgrind log is not empty. tests/valgrind.supp suppresses third-party noise only. OpenCL
# is off under valgrind (OCL_ICD_VENDORS names an empty directory, so the OpenCL checks take
# their documented "no OpenCL platform" branch): PoCL compiles its kernels with LLVM at run
# time, which valgrind runs for minutes and reports JIT noise in; the OpenCL backend is
# checked by the unit tests, in both ordinary and sanitizer builds, instead.
VG_LOGS=""
if [ "${LRR_VALGRIND:-0}" != 0 ]; then
    if ! command -v valgrind >/dev/null 2>&1; then
        echo "FAIL: LRR_VALGRIND is set but valgrind is not installed"
        exit 1
    fi
    VG_SUPP=${LRR_VALGRIND_SUPP:-$SRCDIR/tests/valgrind.supp}
    # an uninstalled lrr is a libtool wrapper script: libtool --mode=execute hands valgrind
    # the real binary with the library path set
    VG_LIBTOOL=${LRR_LIBTOOL:-$(dirname "$LRR")/libtool}
    VG_EXEC=""
    [ -x "$VG_LIBTOOL" ] && VG_EXEC="$VG_LIBTOOL"
    VG_LOGS="$T/valgrind"
    mkdir "$VG_LOGS" "$T/no-icd-valgrind"
    OCL_ICD_VENDORS="$T/no-icd-valgrind"
    export OCL_ICD_VENDORS
    echo "valgrind: $(valgrind --version), suppressions $VG_SUPP, OpenCL off"
fi

# lrr_exec ARGS...: runs lrr (under valgrind with LRR_VALGRIND).
lrr_exec() {
    if [ -z "$VG_LOGS" ]; then
        "$LRR" "$@"
        return
    fi
    set -- valgrind --quiet --error-exitcode=99 --leak-check=full \
        --errors-for-leak-kinds=definite,indirect --show-leak-kinds=definite,indirect \
        --suppressions="$VG_SUPP" --log-file="$VG_LOGS/%p.log" "$LRR" "$@"
    if [ -n "$VG_EXEC" ]; then
        "$VG_EXEC" --mode=execute "$@"
    else
        "$@"
    fi
}

# run ARGS...: runs lrr, stdout in $T/out, stderr in $T/err, exit status in $rc.
run() {
    lrr_exec "$@" >"$T/out" 2>"$T/err"
    rc=$?
}

# value KEY: the value of a "key: value" line of the last stdout.
value() { sed -n "s/^$1: //p" "$T/out" | head -n 1; }

show_err() { sed 's/^/    stderr: /' "$T/err" | head -n 5; }

# expect_rc WANT DESCRIPTION
expect_rc() {
    if [ "$rc" -eq "$1" ]; then pass "$2 (exit $rc)"; else fail "$2: exit $rc, expected $1"; show_err; fi
}

# help_mentions COMMAND OPTION...: COMMAND --help exits 0 and names every OPTION.
help_mentions() {
    cmd=$1
    shift
    run "$cmd" --help
    missing=""
    for opt in "$@"; do
        grep -q -- "$opt" "$T/out" || missing="$missing $opt"
    done
    if [ "$rc" -eq 0 ] && [ -z "$missing" ]; then
        pass "lrr $cmd --help mentions $*"
    else
        fail "lrr $cmd --help (exit $rc), missing:$missing"
    fi
}

# The columns of `lrr solve --csv` and `lrr reference --csv`.
header='subpatch,patch,area,cx,cy,cz,nx,ny,nz,b_r,b_g,b_b'
# The shipped light probe and textured glTF (data/README.md, data/textured/SOURCE.md).
PROBE=$DATA/probes/studio.hdr
BOXTEX=$DATA/textured/BoxTextured.gltf

# small_lrr: the small operator most checks read, $T/small.lrr (LRRFILE), with its n
# (tests/cli/preprocess.sh checks this build itself).
small_lrr() {
    LRRFILE="$T/small.lrr"
    run preprocess cornell -o "$LRRFILE" --patches 30 --levels 1 --hemicube 32 --threads 2
    n=$(value n)
    [ "$rc" -eq 0 ] && [ -s "$LRRFILE" ] && [ -n "$n" ] ||
        { show_err; fatal "preprocess of $LRRFILE: exit $rc"; }
}

# finish: the valgrind check (with LRR_VALGRIND), the count, the exit status; $T is removed
# when every check passed.
finish() {
    if [ -n "$VG_LOGS" ]; then
        dirty=""
        logs=0
        for f in "$VG_LOGS"/*.log; do
            [ -e "$f" ] || continue
            logs=$((logs + 1))
            [ -s "$f" ] && dirty="$dirty $f"
        done
        if [ "$logs" -eq 0 ]; then
            fail "valgrind: no logs in $VG_LOGS"
        elif [ -z "$dirty" ]; then
            pass "valgrind: $logs lrr invocations, no memory errors, no definite or indirect leaks"
        else
            fail "valgrind: reports in$dirty"
            shown=0
            for f in $dirty; do
                shown=$((shown + 1))
                [ "$shown" -le 5 ] && sed 's/^/    /' "$f" | head -n 60
            done
        fi
    fi
    if [ "$failures" -eq 0 ]; then
        rm -rf "$T"
        echo "all $checks checks passed"
        exit 0
    fi
    echo "$failures of $checks checks failed (files kept in $T)"
    exit 1
}
