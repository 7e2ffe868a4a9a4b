#!/bin/sh
# The headless viewer (`lrr view --script`) under xvfb-run with Mesa's software GL: a point
# light moved from the left to the right of the Cornell box must make the left half of the
# screenshot darker and the right half brighter; then a user's session replayed through the
# handlers of the mouse and keys (click, drag, key, scroll statements) must select, drag,
# add, remove and edit lights, switch the emitters and the exposure as lrr view --help says.
# Skips (exit 77) when lrr was built without the viewer (--disable-viewer, no
# GLFW/libepoxy) or xvfb-run is missing.
# Environment: LRR_BIN (the built lrr; default ./lrr), LRR_TEST_TMP (a writable directory).
set -u

LRR=${LRR_BIN:-./lrr}
case $LRR in /*) LRR_ABS=$LRR ;; *) LRR_ABS=$PWD/$LRR ;; esac # the session runs in $T
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
# only; lrr's own leaks are checked by tests/cli/*.sh and the unit tests.
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

# The PNG files themselves (when python3 is there to decode them): "halves A B" checks the
# move above, "pixel F X Y" prints a pixel's R G B, "mean F" the mean luma.
cat >"$T/png.py" <<'EOF'
import struct, sys, zlib
def decode(path):
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
    return w, h, rows
def halves(path):
    w, h, rows = decode(path)
    s = [0.0, 0.0]
    for line in rows:
        for x in range(w):
            if 2 * x + 1 != w:
                s[2 * x >= w] += 0.2126 * line[3 * x] + 0.7152 * line[3 * x + 1] + 0.0722 * line[3 * x + 2]
    return s
if sys.argv[1] == 'halves':
    a, b = halves(sys.argv[2]), halves(sys.argv[3])
    print('ok' if a[0] > a[1] and b[1] > b[0] else 'bad %s %s' % (a, b))
elif sys.argv[1] == 'mean':
    w, h, rows = decode(sys.argv[2])
    print('%.2f' % (sum(0.2126 * r[3 * x] + 0.7152 * r[3 * x + 1] + 0.0722 * r[3 * x + 2]
                        for r in rows for x in range(w)) / (w * h)))
else:
    w, h, rows = decode(sys.argv[2])
    x, y = int(sys.argv[3]), int(sys.argv[4])
    print(rows[y][3 * x], rows[y][3 * x + 1], rows[y][3 * x + 2])
EOF
have_py=0
command -v python3 >/dev/null 2>&1 && have_py=1
if [ "$have_py" = 1 ]; then
    python3 "$T/png.py" halves "$T/left.png" "$T/right.png" >"$T/py" 2>&1
    if [ "$(cat "$T/py")" = ok ]; then pass "the PNG files agree"; else fail "the PNG files: $(cat "$T/py")"; fi
fi

# ---------------------------------------------------------------- a user's session, replayed
# The script's mouse and key statements go through the handlers the GLFW callbacks call
# (tools/view_input.c). Every screenshot prints the luma and the state (lrr view --help).
# Where the Cornell camera (eye 278,273,-800 looking along +z, vertical field of view
# 2 atan(12.5/35), y up) puts a point, and where the ray through a pixel meets the back
# wall z = 559.2, computed here independently of the viewer:
W=160; H=120
proj() { awk -v x="$1" -v y="$2" -v z="$3" -v w=$W -v h=$H 'BEGIN {
    f = h / 2 / (12.5 / 35); printf "%d %d", w / 2 - 0.5 - f * (x - 278) / (z + 800) + 0.5,
    h / 2 - 0.5 - f * (y - 273) / (z + 800) + 0.5 }'; }
# floor PX PY: where the ray through a pixel meets the floor y = 0
floor_at() { awk -v px="$1" -v py="$2" -v w=$W -v h=$H 'BEGIN { t = 12.5 / 35;
    sx = (2 * (px + 0.5) / w - 1) * t * w / h; sy = (1 - 2 * (py + 0.5) / h) * t;
    s = -273 / sy; printf "%.3f %.3f", 278 - sx * s, -800 + s }'; }
back_wall() { awk -v px="$1" -v py="$2" -v w=$W -v h=$H 'BEGIN { t = 12.5 / 35;
    sx = (2 * (px + 0.5) / w - 1) * t * w / h; sy = (1 - 2 * (py + 0.5) / h) * t;
    printf "%.3f %.3f", 278 - sx * 1359.2, 273 + sy * 1359.2 }'; }
# shot N KEY: the value of KEY printed with the N-th screenshot (1-based)
shot() { awk -v n="$1" -v k="$2: " '/^screenshot: / { s++ } s == n && index($0, k) == 1 {
    print substr($0, length(k) + 1); exit }' "$T/session.out"; }
# light_field N I FIELD: a field (pos, dir, rgb, or the kind) of light I at screenshot N
light_field() { shot "$1" "light $2" | awk -v f="$3" '{ if (f == "kind") { print $1; exit }
    for (i = 2; i <= NF; i++) if (index($i, f "=") == 1) print substr($i, length(f) + 2) }'; }
# near A B TOL: |A - B| <= TOL; ratio A B R TOL: |A / B - R| <= TOL
near() { awk -v a="$1" -v b="$2" -v t="$3" 'BEGIN { d = a - b; exit !(a != "" && b != "" && (d < 0 ? -d : d) <= t) }'; }
ratio() { awk -v a="$1" -v b="$2" -v r="$3" -v t="$4" 'BEGIN { d = a / b - r; exit !(b + 0 != 0 && (d < 0 ? -d : d) <= t) }'; }
comp() { echo "$1" | cut -d, -f"$2"; }

# The viewer tone maps as lrr render's PNGs (exposure, extended Reinhard, sRGB): the same
# exposure, camera and size give the same mean luma, to the rasterisers' edges (measured
# 122.6 against 124.3; the clamp the viewer had before gave 144.1).
if [ "$have_py" = 1 ]; then
    "$LRR" render "$T/cb.lrr" -o "$T/render.png" --width 160 --height 120 --camera cornell \
        --exposure 20 >"$T/out" 2>&1
    LIBGL_ALWAYS_SOFTWARE=1 xvfb-run -a -s '-screen 0 640x480x24' "$LRR" view "$T/cb.lrr" \
        --flat --exposure 20 --frames 1 --screenshot "$T/view.png" --width 160 --height 120 \
        >"$T/out" 2>&1
    m_render=$(python3 "$T/png.py" mean "$T/render.png"); m_view=$(python3 "$T/png.py" mean "$T/view.png")
    near "$m_view" "$m_render" 4 && pass "tone curve: mean luma $m_view, lrr render's $m_render" ||
        fail "tone curve: mean luma $m_view, lrr render's $m_render"
fi

set -- $(proj 500 300 279); MX=$1; MY=$2     # the light's marker
QX=100; QY=56                                # where it is dragged: the back wall
set -- $(back_wall $QX $QY); BX=$1; BY=$2
NX=40; NY=115                                # where N puts a light: the floor, in front
set -- $(floor_at $NX $NY); FX=$1; FZ=$2
cat >"$T/session.txt" <<EOF
light point pos=500,300,279 rgb=20000
emitters off
frames 2
screenshot $T/s1.png
click 5 5
screenshot $T/s2.png
click $MX $MY
screenshot $T/s3.png
drag $MX $MY $QX $QY frames=6
screenshot $T/s4.png
key T
screenshot $T/s5.png
key +
screenshot $T/s6.png
key -
key C
screenshot $T/s7.png
mouse $NX $NY
key N
screenshot $T/s8.png
key Delete
screenshot $T/s9.png
key L
screenshot $T/s10.png
key L
screenshot $T/s11.png
key ]
screenshot $T/s12.png
key [
key [
screenshot $T/s13.png
key 0
screenshot $T/s14.png
scroll 2
key P
screenshot $T/s15.png
fly W 0.5
screenshot $T/s16.png
fly QD 0.25 shift
screenshot $T/s17.png
EOF
(cd "$T" && LIBGL_ALWAYS_SOFTWARE=1 xvfb-run -a -s '-screen 0 640x480x24' "$LRR_ABS" view \
    "$T/cb.lrr" --script "$T/session.txt" --width $W --height $H >"$T/session.out" 2>"$T/err")
rc=$?
if [ "$rc" -ne 0 ] || [ "$(grep -c '^screenshot: ' "$T/session.out")" -lt 15 ]; then
    fail "the session: exit $rc"; sed 's/^/    /' "$T/err" | head -n 10; exit 1
fi
pass "the session ran ($(grep -c '^screenshot: ' "$T/session.out") screenshots)"

# The automatic exposure is the library's (lrr_render_auto_exposure), as lrr animate's.
printf 'light point pos=500,300,279 rgb=20000\nemitters off\nframes 1\n' >"$T/a1.txt"
"$LRR" animate "$T/cb.lrr" --lights "$T/a1.txt" -o "$T/a1" --width 16 --height 16 >"$T/a1.out" 2>&1
x_anim=$(value exposure "$T/a1.out")
ratio "$(shot 1 exposure)" "$x_anim" 1 1e-4 &&
    pass "automatic exposure $(shot 1 exposure) = lrr animate's $x_anim" ||
    fail "automatic exposure $(shot 1 exposure), lrr animate's $x_anim"

# click: away from every marker selects nothing; on the marker selects the light, whose
# marker turns from white to yellow
[ "$(shot 2 selected)" = none ] && pass "a click at 5,5 selects nothing" ||
    fail "a click at 5,5 selected $(shot 2 selected)"
[ "$(shot 3 selected)" = 0 ] && pass "a click on the marker at $MX,$MY selects light 0" ||
    fail "a click on the marker at $MX,$MY: selected $(shot 3 selected)"
if [ "$have_py" = 1 ]; then
    set -- $(python3 "$T/png.py" pixel "$T/s2.png" $MX $MY); c2="$*"
    set -- $(python3 "$T/png.py" pixel "$T/s3.png" $MX $MY); c3="$*"
    if echo "$c2 $c3" | awk '{ exit !($3 > 200 && $4 > 200 && $6 < 80) }'; then
        pass "the marker: white ($c2), yellow once selected ($c3)"
    else
        fail "the marker's pixel: $c2 before, $c3 selected"
    fi
fi

# drag: the light follows the mouse over the surfaces, lifted 5% of the box's diagonal
# (963) off the back wall towards the eye; left half darker, right half brighter
pos=$(light_field 4 0 pos)
if near "$(comp "$pos" 1)" "$BX" 1 && near "$(comp "$pos" 2)" "$BY" 1 &&
    near "$(comp "$pos" 3)" 511.0 3; then
    pass "drag to $QX,$QY: the light at $pos (back wall hit $BX,$BY,559.2)"
else
    fail "drag to $QX,$QY: the light at $pos, expected $BX,$BY,511"
fi
gt "$(shot 3 left_luma)" "$(shot 4 left_luma)" && gt "$(shot 4 right_luma)" "$(shot 3 right_luma)" &&
    pass "the drag darkened the left half ($(shot 3 left_luma) -> $(shot 4 left_luma)) and brightened the right ($(shot 3 right_luma) -> $(shot 4 right_luma))" ||
    fail "the drag: left $(shot 3 left_luma) -> $(shot 4 left_luma), right $(shot 3 right_luma) -> $(shot 4 right_luma)"

# T: point -> spot (straight down until dragged): its cone lights less than the point did
if [ "$(light_field 5 0 kind)" = spot ] && [ "$(light_field 5 0 dir)" = 0,-1,0 ] &&
    gt "$(shot 4 luma)" "$(shot 5 luma)"; then
    pass "T: the point light became a spot pointing down, the picture darker"
else
    fail "T: $(shot 5 'light 0'), luma $(shot 4 luma) -> $(shot 5 luma)"
fi
# + and C: intensity x1.25; the colour cycle's next step after white is warm (1, 0.8, 0.55)
rgb6=$(light_field 6 0 rgb); rgb7=$(light_field 7 0 rgb)
if ratio "$(comp "$rgb6" 1)" 20000 1.25 1e-6 && gt "$(shot 6 luma)" "$(shot 5 luma)"; then
    pass "+: intensity x1.25 ($rgb6), brighter"
else
    fail "+: rgb $rgb6, luma $(shot 5 luma) -> $(shot 6 luma)"
fi
if ratio "$(comp "$rgb7" 1)" 20000 1 1e-6 && ratio "$(comp "$rgb7" 2)" 20000 0.8 1e-6 &&
    ratio "$(comp "$rgb7" 3)" 20000 0.55 1e-6; then
    pass "- then C: back to 20000, warm ($rgb7)"
else
    fail "- then C: rgb $rgb7"
fi
# N adds a light (selected) where the mouse points, Delete removes it: the picture as before
# (to 0.5: light 0's marker, 9x9 pixels, was yellow, selected, and is white again, 0.2)
if [ "$(shot 8 lights)" = 2 ] && [ "$(shot 8 selected)" = 1 ] && [ "$(shot 9 lights)" = 1 ] &&
    gt "$(shot 8 luma)" "$(shot 7 luma)" && near "$(shot 9 luma)" "$(shot 7 luma)" 0.5; then
    pass "N: a second light, brighter ($(shot 7 luma) -> $(shot 8 luma)); Delete: $(shot 9 luma) again"
else
    fail "N/Delete: lights $(shot 8 lights)/$(shot 9 lights), selected $(shot 8 selected), luma $(shot 7 luma) -> $(shot 8 luma) -> $(shot 9 luma)"
fi
npos=$(light_field 8 1 pos)
if near "$(comp "$npos" 1)" "$FX" 1 && near "$(comp "$npos" 2)" 48.2 3 &&
    near "$(comp "$npos" 3)" "$FZ" 1; then
    pass "N: the new light at $npos, 48 above the floor where the mouse points ($FX,0,$FZ)"
else
    fail "N: the new light at $npos, expected $FX,48,$FZ"
fi
# L: the Cornell box's ceiling lamp on (brighter), off again (as before)
if [ "$(shot 10 emitters)" = on ] && gt "$(shot 10 luma)" "$(shot 9 luma)" &&
    [ "$(shot 11 emitters)" = off ] && near "$(shot 11 luma)" "$(shot 9 luma)" 0.3; then
    pass "L: the ceiling lamp on ($(shot 9 luma) -> $(shot 10 luma)) and off ($(shot 11 luma))"
else
    fail "L: emitters $(shot 10 emitters)/$(shot 11 emitters), luma $(shot 9 luma) -> $(shot 10 luma) -> $(shot 11 luma)"
fi
# ] and [: exposure x1.25 and /1.25, the picture brighter and darker
if ratio "$(shot 12 exposure)" "$(shot 11 exposure)" 1.25 1e-6 &&
    ratio "$(shot 13 exposure)" "$(shot 11 exposure)" 0.8 1e-6 &&
    gt "$(shot 12 luma)" "$(shot 11 luma)" && gt "$(shot 11 luma)" "$(shot 13 luma)"; then
    pass "] and [: exposure x1.25, /1.25 (luma $(shot 13 luma) < $(shot 11 luma) < $(shot 12 luma))"
else
    fail "] and [: exposure $(shot 11 exposure) -> $(shot 12 exposure) -> $(shot 13 exposure), luma $(shot 11 luma) $(shot 12 luma) $(shot 13 luma)"
fi
# 0: automatic again, for the light as it is now: what lrr animate computes for it
printf 'light %s\nemitters off\nframes 1\n' "$(shot 14 'light 0')" >"$T/a2.txt"
"$LRR" animate "$T/cb.lrr" --lights "$T/a2.txt" -o "$T/a2" --width 16 --height 16 >"$T/a2.out" 2>&1
ratio "$(shot 14 exposure)" "$(value exposure "$T/a2.out")" 1 1e-4 &&
    pass "0: the automatic exposure $(shot 14 exposure) = lrr animate's for this light" ||
    fail "0: exposure $(shot 14 exposure), lrr animate's $(value exposure "$T/a2.out") ($(head -c 200 "$T/a2.out"))"
# scroll 2: the eye 0.9^2 of the way from the target (279.6 - 0.81 * 1079.6 = -594.876)
near "$(comp "$(shot 15 eye)" 3)" -594.876 0.01 && pass "scroll 2: eye at $(shot 15 eye)" ||
    fail "scroll 2: eye at $(shot 15 eye)"
# fly: the held keys through view_input_fly_keys, as the frame loop's GLFW keys: 0.4 of the
# scene's diagonal (sqrt(556^2 + 548.8^2 + 559.2^2) = 960.7404) a second, x4 with shift.
# eye_at NAME: the eye of screenshot NAME (by name: P's pictures are counted among them)
eye_at() { awk -v f="$T/$1" '/^screenshot: / { at = $2 == f } at && /^eye: / { print $2; exit }' \
    "$T/session.out"; }
# moved A B: how far the eye moved along x, y, z from screenshot A to screenshot B
moved() { awk -v a="$(eye_at "$1")" -v b="$(eye_at "$2")" 'BEGIN { split(a, p, ",");
    split(b, q, ","); printf "%.4f %.4f %.4f\n", q[1] - p[1], q[2] - p[2], q[3] - p[3] }'; }
# W 0.5 s: 0.2 diag = 192.148 forward (the camera looks along +z)
set -- $(moved s15.png s16.png)
near "$1" 0 1e-3 && near "$2" 0 1e-3 && near "$3" 192.148 0.01 &&
    pass "fly W 0.5: the eye 192.148 forward ($*)" || fail "fly W 0.5: the eye moved $*"
# Q and D 0.25 s with shift: 0.4 diag = 384.296 down and to the right (-x, seen from -z)
set -- $(moved s16.png s17.png)
near "$1" -384.296 0.01 && near "$2" -384.296 0.01 && near "$3" 0 1e-3 &&
    pass "fly QD 0.25 shift: the eye 384.296 down and right ($*)" ||
    fail "fly QD 0.25 shift: the eye moved $*"
# P: the picture saved in the current directory
[ "$(head -c 4 "$T/lrr-view-000.png" 2>/dev/null | tail -c 3)" = PNG ] &&
    pass "P: lrr-view-000.png written" || fail "P: no lrr-view-000.png"

# Escape ends the script there: the screenshot after it is not taken
printf 'frames 1\nkey Escape\nscreenshot %s\n' "$T/never.png" >"$T/esc.txt"
LIBGL_ALWAYS_SOFTWARE=1 xvfb-run -a -s '-screen 0 640x480x24' "$LRR" view "$T/cb.lrr" \
    --script "$T/esc.txt" --width 64 --height 64 >"$T/out" 2>"$T/err"
rc=$?
[ "$rc" -eq 0 ] && [ ! -e "$T/never.png" ] && [ -n "$(value frames "$T/out")" ] &&
    pass "Escape: the script ends, the split is printed" ||
    fail "Escape: exit $rc, never.png $( [ -e "$T/never.png" ] && echo written || echo absent)"

# a key the viewer does not have, and a click in lrr animate, are usage errors naming the line
printf 'frames 1\nkey X\n' >"$T/bad.txt"
"$LRR" view "$T/cb.lrr" --script "$T/bad.txt" >"$T/out" 2>"$T/err"
rc=$?
[ "$rc" -eq 2 ] && grep -q "bad.txt' line 2: key: 'X'" "$T/err" &&
    pass "key X: exit 2 naming the line" || fail "key X: exit $rc: $(cat "$T/err")"

printf 'frames 1\nfly WX 1\n' >"$T/bad.txt"
"$LRR" view "$T/cb.lrr" --script "$T/bad.txt" >"$T/out" 2>"$T/err"
rc=$?
[ "$rc" -eq 2 ] && grep -q "bad.txt' line 2: fly: KEYS" "$T/err" &&
    pass "fly WX: exit 2 naming the line" || fail "fly WX: exit $rc: $(cat "$T/err")"

[ "$failures" -eq 0 ] || exit 1
exit 0
