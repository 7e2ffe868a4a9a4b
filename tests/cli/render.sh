#!/bin/sh
# lrr render: PNG and OpenEXR pictures, cameras, formats, --emission-scale.
. "$(dirname "$0")/harness.sh"

small_lrr

# ---------------------------------------------------------------- render
PNG="$T/b.png"
run render "$LRRFILE" -o "$PNG" --width 64 --height 48
sig=$(od -An -tx1 -N8 "$PNG" 2>/dev/null | tr -d ' \n')
if [ "$rc" -eq 0 ] && [ "$sig" = 89504e470d0a1a0a ]; then
    pass "render writes a PNG ($(wc -c <"$PNG" | tr -d ' ') bytes)"
else
    fail "render (exit $rc), signature '$sig'"
    show_err
fi

# --csv: the radiosity drawn is what lrr solve computes for the same emission
run render "$LRRFILE" -o "$T/csv.png" --width 16 --height 16 --emission-scale 2 --csv "$T/drawn.csv"
"$LRR" solve "$LRRFILE" --emission-scale 2 --csv "$T/solved.csv" >/dev/null 2>&1
max=$("$LRR" compare "$T/drawn.csv" "$T/solved.csv" 2>/dev/null | sed -n 's/^max_rel: //p')
if [ "$rc" -eq 0 ] && grep -q "^csv: $T/drawn.csv" "$T/out" &&
    awk -v v="$max" 'BEGIN { exit !(v ~ /^[0-9.eE+-]+$/ && v + 0 <= 1e-6) }'; then
    pass "render --csv: the radiosity drawn, lrr solve's within max_rel $max"
else
    fail "render --csv (exit $rc), max_rel '$max' against lrr solve --csv"
    show_err
fi

# cameras: --eye/--target (and --up, --fov) give a pinhole camera; each bad value is a usage
# error naming its option
run render "$LRRFILE" -o "$T/eye.png" --width 32 --height 24 --eye 278,273,-800 \
    --target 278,273,0 --up 0,1,0 --fov 45
sig=$(od -An -tx1 -N8 "$T/eye.png" 2>/dev/null | tr -d ' \n')
if [ "$rc" -eq 0 ] && [ "$sig" = 89504e470d0a1a0a ]; then
    pass "render --eye --target --up --fov writes a PNG"
else
    fail "render --eye --target (exit $rc), signature '$sig'"
    show_err
fi
# bad_camera OPTION DESCRIPTION ARGS...: exit 2, a message naming OPTION, no picture
bad_camera() {
    opt=$1 what=$2
    shift 2
    rm -f "$T/bad.png"
    run render "$LRRFILE" -o "$T/bad.png" --width 8 --height 8 "$@"
    if [ "$rc" -eq 2 ] && grep -q -- "$opt" "$T/err" && [ ! -e "$T/bad.png" ]; then
        pass "render: $what is a usage error naming $opt"
    else
        fail "render: $what: exit $rc, expected 2 and a message naming $opt"
        show_err
    fi
}
bad_camera --target "eye = target" --eye 1,2,3 --target 1,2,3
bad_camera --up "up parallel to the view" --eye 0,0,0 --target 0,5,0
bad_camera --up "up parallel (explicit)" --eye 0,0,0 --target 1,0,0 --up -2,0,0
bad_camera --up "a zero up" --eye 0,0,0 --target 1,0,0 --up 0,0,0
bad_camera --eye "a non-finite eye" --eye 0,nan,0 --target 1,0,0
bad_camera --target "an infinite target" --eye 0,0,0 --target inf,0,0
bad_camera --eye "two coordinates" --eye 0,0 --target 1,0,0
bad_camera --eye "four coordinates" --eye 0,0,0,0 --target 1,0,0
bad_camera --up "a non-number up" --eye 0,0,0 --target 1,0,0 --up a,b,c
bad_camera --fov "fov 0" --fov 0
bad_camera --fov "fov 180" --fov 180
bad_camera --fov "fov -10" --fov -10
bad_camera --eye "--eye without --target" --eye 0,0,0
bad_camera --eye "--target without --eye" --target 0,0,0
bad_camera --eye "--eye with --camera" --eye 0,0,0 --target 1,0,0 --camera fit

# formats: .exr (any case) is linear OpenEXR, --format wins over the extension, an unknown
# extension without --format is refused
run render "$LRRFILE" -o "$T/lin.EXR" --width 32 --height 16
sig=$(od -An -tx1 -N4 "$T/lin.EXR" 2>/dev/null | tr -d ' \n')
if [ "$rc" -eq 0 ] && [ "$sig" = 762f3101 ]; then
    pass "render -o X.EXR writes OpenEXR ($(wc -c <"$T/lin.EXR" | tr -d ' ') bytes)"
else
    fail "render -o X.EXR (exit $rc), signature '$sig'"
    show_err
fi
run render "$LRRFILE" -o "$T/lin.png" --format exr --width 32 --height 16
sig=$(od -An -tx1 -N4 "$T/lin.png" 2>/dev/null | tr -d ' \n')
if [ "$rc" -eq 0 ] && [ "$sig" = 762f3101 ]; then
    pass "render --format exr wins over the .png extension"
else
    fail "render --format exr -o X.png (exit $rc), signature '$sig'"
fi
rm -f "$T/pic.jpg"
run render "$LRRFILE" -o "$T/pic.jpg" --width 8 --height 8
if [ "$rc" -eq 2 ] && grep -q 'unknown picture format' "$T/err" && grep -q -- '--format' "$T/err" &&
    [ ! -e "$T/pic.jpg" ]; then
    pass "render -o X.jpg is refused (exit 2, suggests --format)"
else
    fail "render -o X.jpg: exit $rc, expected 2 and a message"
    show_err
fi
run render "$LRRFILE" -o "$T/pic.jpg" --format tiff
expect_rc 2 "render --format tiff is a usage error"
# --emission-scale S scales the solve, which is linear and exact for S = 2 (a power of two):
# S = 2 at exposure 1 is the picture of S = 1 at exposure 2, bit for bit, and not that of
# S = 1 at exposure 1. (render listed the option but refused it as "unknown option '2'".)
run render "$LRRFILE" -o "$T/s2.png" --width 32 --height 24 --emission-scale 2 --exposure 1
rc1=$rc
run render "$LRRFILE" -o "$T/x2.png" --width 32 --height 24 --emission-scale 1 --exposure 2
rc2=$rc
run render "$LRRFILE" -o "$T/s1.png" --width 32 --height 24 --exposure 1
if [ "$rc1$rc2$rc" = 000 ] && cmp -s "$T/s2.png" "$T/x2.png" && ! cmp -s "$T/s2.png" "$T/s1.png"; then
    pass "render --emission-scale 2 = --exposure 2, bit for bit"
else
    fail "render --emission-scale 2 vs --exposure 2 (exit $rc1 $rc2 $rc)"; show_err
fi


# one X,Y,Z parser for every option (tools/cli_util.c): three finite float numbers, single
# commas, nothing else
for v in '1, 2, 3' '1e39,0,0' '1,2' '1,2,3,'; do
    run render "$LRRFILE" -o "$T/e.png" --eye "$v" --target 0,0,0
    if [ "$rc" -eq 2 ] && grep -q -- "--eye: '$v' is not three finite numbers X,Y,Z" "$T/err"; then
        pass "render --eye '$v' is a usage error naming the option"
    else
        fail "render --eye '$v': exit $rc"; show_err
    fi
done

finish
