#!/bin/sh
# The man pages (man/): each formats without a warning (groff -man -ww, the PostScript and
# the UTF-8 device) and renders with man -l; lrr.1 and lrr-bench.1 have a section for every
# command of the tool's --help and, in it, exactly the options of that command's --help
# (so they cannot drift: `make update-docs` regenerates them); the example of lrr.3
# compiles against the built library and runs.
# Environment: LRR_BIN, LRR_BENCH_BIN, LRR_SRCDIR, LRR_LIBDIR, LRR_TEST_TMP (make check).
set -u
top=${LRR_SRCDIR:-$(cd "$(dirname "$0")/.." && pwd)}
LRR=${LRR_BIN:-$top/lrr}
BENCH=${LRR_BENCH_BIN:-$top/lrr-bench}
libdir=${LRR_LIBDIR:-$top/.libs}
for tool in groff man; do
    command -v "$tool" >/dev/null 2>&1 || {
        echo "man: $tool not found (Debian: groff-base, man-db; scripts/bootstrap installs them): skipped"
        exit 77
    }
done
T=$(mktemp -d "${LRR_TEST_TMP:-${TMPDIR:-/tmp}}/man.XXXXXX") || exit 1
trap 'rm -rf "$T"' EXIT
failures=0
pass() { echo "PASS: $1"; }
fail() { failures=$((failures + 1)); echo "FAIL: $1"; }

for page in lrr.1 lrr-bench.1 lrr.3; do
    src=$top/man/$page
    for dev in ps utf8; do
        if groff -man -ww -T"$dev" -z "$src" 2>"$T/warn" && [ ! -s "$T/warn" ]; then
            pass "$page: groff -man -ww -T$dev: no warnings"
        else
            fail "$page: groff -man -ww -T$dev:"; sed 's/^/    /' "$T/warn" | head -n 10
        fi
    done
    name=${page%.*}
    if LC_ALL=C MANWIDTH=80 man -l "$src" >"$T/out" 2>"$T/err" && [ ! -s "$T/err" ] &&
        grep -q '^NAME' "$T/out" && grep -q "^ *$name - " "$T/out" &&
        grep -q '^SEE ALSO' "$T/out"; then
        pass "$page: man -l renders ($(wc -l < "$T/out") lines, NAME and SEE ALSO)"
    else
        fail "$page: man -l"; sed 's/^/    /' "$T/err" | head -n 5
    fi
done

# help_options: stdin (a --help text) -> its options, one a line: every -x/--name in the
# option terms (lines indented 1-4 columns that start with '-', up to a gap of two spaces)
help_options() {
    sed -n 's/^ \{1,4\}\(-.*\)/\1/p' | sed 's/  .*//' | tr ' ,' '\n\n' | grep -- '^-' |
        sed 's/[^a-zA-Z0-9-].*//' | sort -u
}
# page_options PAGE CMD: the options in the .TP terms of the page's section on CMD
page_options() {
    sed -n "/^\\.SS \"$2\"\$/,/^\\.S[SH] /p" "$1" | sed -n '/^\.TP$/{n;p;}' |
        sed 's/\\-/-/g; s/\\f[BIR]//g' | grep -- '^-' | sed 's/  .*//' | tr ' ,' '\n\n' |
        grep -- '^-' | sed 's/[^a-zA-Z0-9-].*//' | sort -u
}
for pair in "$LRR:lrr" "$BENCH:lrr-bench"; do
    bin=${pair%:*} page=$top/man/${pair##*:}.1 name=${pair##*:}
    cmds=$("$bin" --help | sed -n '/^Commands:/,/^$/s/^  \([a-z0-9][a-z0-9]*\) .*/\1/p')
    sections=$(sed -n 's/^\.SS "\(.*\)"$/\1/p' "$page")
    if [ -n "$cmds" ] && [ "$(echo "$cmds" | sort)" = "$(echo "$sections" | sort)" ]; then
        pass "$name.1: a section for each of the $(echo "$cmds" | wc -l) commands of $name --help"
    else
        fail "$name.1: sections '$(echo $sections)', commands '$(echo $cmds)' (make update-docs)"
    fi
    for cmd in $cmds; do
        "$bin" "$cmd" --help | help_options > "$T/help"
        page_options "$page" "$cmd" > "$T/page"
        if [ -s "$T/help" ] && cmp -s "$T/help" "$T/page"; then
            pass "$name.1 $cmd: the $(wc -l < "$T/help") options of '$name $cmd --help'"
        else
            fail "$name.1 $cmd: options differ from '$name $cmd --help' (< help, > page; make update-docs):"
            diff "$T/help" "$T/page" | grep '^[<>]' | sed 's/^/    /'
        fi
    done
done

# lrr.3's example, as printed (the .nf block between EXAMPLE and SEE ALSO, \e unescaped)
sed -n '/^\.SH EXAMPLE/,/^\.SH SEE ALSO/p' "$top/man/lrr.3" | sed '1,2d;$d' | sed '$d' |
    sed 's/\\e/\\/g' > "$T/example.c"
builddir=$(dirname "$libdir")
if ! command -v "${CC:-cc}" >/dev/null 2>&1 || [ ! -f "$libdir/liblrr.so" ]; then
    echo "man: no C compiler or no $libdir/liblrr.so: lrr.3's example not compiled"
elif "${CC:-cc}" ${LRR_SANITIZE_CFLAGS:-} -std=c11 -Wall -Wextra -Werror -I"$top/include" -I"$builddir/include" \
        "$T/example.c" -L"$libdir" -llrr -o "$T/example" 2>"$T/err" &&
    LD_LIBRARY_PATH="$libdir${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" "$T/example" >"$T/out" 2>&1 &&
    grep -Eq '^B\[0\] = [0-9.e-]+ [0-9.e-]+ [0-9.e-]+$' "$T/out"; then
    pass "lrr.3: the example compiles (-Wall -Wextra -Werror) and solves the Cornell box: $(cat "$T/out")"
else
    fail "lrr.3: the example:"; sed 's/^/    /' "$T/err" "$T/out" | head -n 10
fi

[ "$failures" -eq 0 ] && echo "man: all passed"
exit $((failures != 0))
