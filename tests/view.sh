#!/bin/sh
# The headless viewer (`lrr view --script`) under xvfb-run with Mesa's software GL: a point
# light moved from the left to the right of the Cornell box must make the left half of the
# screenshot darker and the right half brighter. Skips (exit 77) when lrr was built without
# the viewer (--disable-viewer, no GLFW/libepoxy) or xvfb-run is missing.
# Environment: LRR_BIN (the built lrr; default ./lrr), LRR_TEST_TMP (a writable directory).
set -u

LRR=${LRR_BIN:-./lrr}
TMPROOT=${LRR_TEST_TMP:-${TMPDIR:-/tmp}}
if [ ! -x "$LRR" ]; then
    echo "FAIL: LRR_BIN='$LRR' is not an executable"
    exit 1
fi
if "$LRR" view /nonexistent.lrr 2>&1 | grep -q 'built without the viewer'; then
    echo "SKIP: lrr was built without the viewer"
    exit 77
fi
if ! command -v xvfb-run >/dev/null 2>&1; then
    echo "SKIP: xvfb-run is not installed (Debian: apt-get install xvfb xauth)"
    exit 77
fi
T=$(mktemp -d "$TMPROOT/view.XXXXXX") || { echo "FAIL: cannot create a directory in $TMPROOT"; exit 1; }
trap 'rm -rf "$T"' EXIT
failures=0
pass() { echo "PASS: $1"; }
fail() { failures=$((failures + 1)); echo "FAIL: $1"; }
value() { sed -n "s/^$1: //p" "$2" | sed -n "${3:-1}p"; }
# gt A B: A > B for decimal numbers
gt() { awk -v a="$1" -v b="$2" 'BEGIN { exit !(a + 0 > b + 0) }'; }

# without a display: a clear message, no crash
env -u DISPLAY -u WAYLAND_DISPLAY "$LRR" view /nonexistent.lrr --frames 1 >"$T/out" 2>"$T/err"
rc=$?
# (the operator is loaded first: a missing file fails before the display is looked at)
[ "$rc" -eq 1 ] && pass "a missing operator: exit 1" || fail "a missing operator: exit $rc"

if ! "$LRR" preprocess cornell -o "$T/cb.lrr" --patches 100 --levels 1 --hemicube 16 \
    >"$T/out" 2>"$T/err"; then
    fail "preprocess cornell"; sed 's/^/    /' "$T/err"; exit 1
fi
env -u DISPLAY -u WAYLAND_DISPLAY "$LRR" view "$T/cb.lrr" --frames 1 >"$T/out" 2>"$T/err"
rc=$?
if [ "$rc" -eq 1 ] && grep -q 'no display: use --screenshot with xvfb-run, or set DISPLAY' "$T/err"; then
    pass "no display: exit 1 with a message"
else
    fail "no display: exit $rc, stderr: $(head -c 300 "$T/err")"
fi

printf 'light point pos=500,300,279 rgb=20000\nmove 5 pos=1,1,1\n' >"$T/bad.txt"
"$LRR" view "$T/cb.lrr" --script "$T/bad.txt" >"$T/out" 2>"$T/err"
rc=$?
if [ "$rc" -eq 2 ] && grep -q "bad.txt' line 2" "$T/err"; then
    pass "a bad script line: exit 2 naming the line"
else
    fail "a bad script line: exit $rc, stderr: $(head -c 300 "$T/err")"
fi

# In sanitizer builds (make check sets ASAN_OPTIONS): Mesa's DRI driver, whose JIT-built
# code allocates, is unloaded at exit, so LeakSanitizer reports its leaks from an unknown
# module that no suppression can name. The viewer's runs under Xvfb check memory errors
# only; lrr's own leaks are checked by tests/cli.sh and the unit tests.
ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0"
export ASAN_OPTIONS

# The Cornell camera looks along +z, so the picture's left is +x: the light starts at
# x = 500 (left) and moves to x = 60 (right), with the ceiling light switched off.
cat >"$T/move.txt" <<EOF
light point pos=500,300,279 rgb=20000
emitters off
frames 3
screenshot $T/left.png
move 0 pos=60,300,279 frames=30
EOF
start=$(date +%s)
LIBGL_ALWAYS_SOFTWARE=1 xvfb-run -a -s '-screen 0 640x480x24' "$LRR" view "$T/cb.lrr" \
    --script "$T/move.txt" --screenshot "$T/right.png" --width 160 --height 120 \
    >"$T/out" 2>"$T/err"
rc=$?
secs=$(($(date +%s) - start))
if [ "$rc" -ne 0 ]; then
    fail "headless run: exit $rc"; sed 's/^/    /' "$T/err" | head -n 10; exit 1
fi
pass "headless run under xvfb-run (${secs} s, $(value fps "$T/out") frames/s)"
l1=$(value left_luma "$T/out" 1); r1=$(value right_luma "$T/out" 1)
l2=$(value left_luma "$T/out" 2); r2=$(value right_luma "$T/out" 2)
for f in left.png right.png; do
    if [ "$(head -c 4 "$T/$f" | tail -c 3)" = PNG ]; then pass "$f is a PNG"; else fail "$f is not a PNG"; fi
done
gt "$l1" "$r1" && pass "light on the left: left half brighter ($l1 > $r1)" ||
    fail "light on the left: left half $l1, right half $r1"
gt "$r2" "$l2" && pass "light moved right: right half brighter ($r2 > $l2)" ||
    fail "light moved right: left half $l2, right half $r2"
gt "$l1" "$l2" && gt "$r2" "$r1" && pass "the move darkened the left half and brightened the right" ||
    fail "the move: left $l1 -> $l2, right $r1 -> $r2"

# The halves again from the PNG files themselves (when python3 is there to decode them).
if command -v python3 >/dev/null 2>&1; then
    python3 - "$T/left.png" "$T/right.png" >"$T/py" 2>&1 <<'EOF'
import struct, sys, zlib
def halves(path):
    d = open(path, 'rb').read()
    pos, idat = 8, b''
    while pos < len(d):
        n, kind = struct.unpack('>I4s', d[pos:pos + 8])
        if kind == b'IHDR':
            w, h, depth, colour = struct.unpack('>IIBB', d[pos + 8:pos + 18])
            assert depth == 8 and colour == 2
        if kind == b'IDAT':
            idat += d[pos + 8:pos + 8 + n]
        pos += 12 + n
    raw, stride, rows, prev = zlib.decompress(idat), 3 * w, [], bytearray(3 * w)
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - 3] if i >= 3 else 0
            b, c = prev[i], prev[i - 3] if i >= 3 else 0
            p = a + b - c
            pr = a if abs(p - a) <= abs(p - b) and abs(p - a) <= abs(p - c) else b if abs(p - b) <= abs(p - c) else c
            line[i] = (line[i] + [0, a, b, (a + b) // 2, pr][f]) & 255
        rows.append(line)
        prev = line
    s = [0.0, 0.0]
    for line in rows:
        for x in range(w):
            if 2 * x + 1 != w:
                s[2 * x >= w] += 0.2126 * line[3 * x] + 0.7152 * line[3 * x + 1] + 0.0722 * line[3 * x + 2]
    return s
a, b = halves(sys.argv[1]), halves(sys.argv[2])
print('ok' if a[0] > a[1] and b[1] > b[0] else 'bad %s %s' % (a, b))
EOF
    if [ "$(cat "$T/py")" = ok ]; then pass "the PNG files agree"; else fail "the PNG files: $(cat "$T/py")"; fi
fi

[ "$failures" -eq 0 ] || exit 1
exit 0
