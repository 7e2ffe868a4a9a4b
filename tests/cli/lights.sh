#!/bin/sh
# Moving lights: solve --light and lrr animate's light scripts.
. "$(dirname "$0")/harness.sh"

# ---------------------------------------------------------------- moving lights
LTFILE="$T/lights.lrr"
run preprocess cornell -o "$LTFILE" --patches 100 --levels 1 --hemicube 16
# a point light near the green wall (x = 0) lights the x < 278 half more than the other
run solve "$LTFILE" --light 'point pos=60,300,279 rgb=20000' --no-scene-emission \
    --csv "$T/light-left.csv" --repeat 1
if [ "$rc" -eq 0 ] && [ "$(value lights)" = 1 ] && [ -n "$(value direct_light_seconds)" ] &&
    awk -F, 'NR > 1 { if ($4 < 278) l += $3 * $10; else r += $3 * $10 }
             END { exit !(l > 1.5 * r && r > 0) }' "$T/light-left.csv"; then
    pass "solve --light point near the x = 0 wall: that half gets more light"
else
    fail "solve --light (exit $rc)"; show_err
fi
run solve "$LTFILE" --light 'spot pos=278,500,279 dir=0,-1,0 angle=20 soft=5 rgb=1e5' \
    --light 'sun dir=0,1,0 rgb=1' --light 'area pos=278,540,279 u=100,0,0 v=0,0,100 rgb=5'
if [ "$rc" -eq 0 ] && [ "$(value lights)" = 3 ]; then
    pass "solve with a spot, a sun and an area light"
else
    fail "solve with three lights (exit $rc)"; show_err
fi
# animate: a light crossing the box, one picture per frame. The script is the one grammar
# of lrr view --script too (tools/cli_script.c): statements run in order, so emitters off
# comes before the frames it is meant for, and the path moves its light during them.
cat > "$T/move.txt" <<'EOS'
# from the green wall to the red one
light point pos=60,300,279 rgb=20000
light sun dir=0,1,0 rgb=0.5
emitters off
path 0 60,300,279 278,300,279 500,300,279
frames 3
EOS
run animate "$LTFILE" --lights "$T/move.txt" -o "$T/frames" --width 64 --height 64
if [ "$rc" -eq 0 ] && [ "$(value frames)" = 3 ] && [ -s "$T/frames/frame_0000.png" ] &&
    [ -s "$T/frames/frame_0002.png" ] && [ ! -e "$T/frames/frame_0003.png" ] &&
    [ "$(grep -c '^frame: ' "$T/out")" = 3 ] && [ -n "$(value exposure)" ]; then
    pass "animate: 3 frames written, the split printed per frame"
else
    fail "animate (exit $rc)"; show_err
fi
# the shadow rays' error budget: the same frames, fewer rays; out of range is a usage error
run animate "$LTFILE" --lights "$T/move.txt" -o "$T/budget" --width 32 --height 32 \
    --shadow-tolerance 0.05
if [ "$rc" -eq 0 ] && [ "$(value frames)" = 3 ] && [ -s "$T/budget/frame_0002.png" ]; then
    pass "animate --shadow-tolerance 0.05: 3 frames"
else
    fail "animate --shadow-tolerance (exit $rc)"; show_err
fi
run animate "$LTFILE" --lights "$T/move.txt" -o "$T/budget" --shadow-tolerance 0.7
expect_rc 2 "animate --shadow-tolerance 0.7 is rejected"
printf 'light point pos=1,2,3\npath 0 1,2,3\n' > "$T/bad.txt"
run animate "$LTFILE" --lights "$T/bad.txt" -o "$T/frames"
expect_rc 2 "animate: a path of one point is rejected"
if grep -q "bad.txt' line 2" "$T/err"; then pass "the error names the file and line"; else fail "no line in: $(cat "$T/err")"; fi
# The frames a script draws: frames N, and the frames=N of move and path (a move with no
# frames after it is an error, not a silent no-op); the viewer's input is refused.
printf 'light point pos=60,300,279 rgb=20000\nmove 0 pos=500,300,279 frames=2\npath 0 1,2,3 4,5,6\nframes 1\nremove 0\nframes 2\n' > "$T/count.txt"
run animate "$LTFILE" --lights "$T/count.txt" -o "$T/count" --width 16 --height 16
if [ "$rc" -eq 0 ] && [ "$(value frames)" = 5 ] && [ -s "$T/count/frame_0004.png" ] &&
    [ ! -e "$T/count/frame_0005.png" ]; then
    pass "animate: move frames=2 + frames 1 + frames 2 = 5 pictures"
else
    fail "animate: frames $(value frames) (exit $rc)"; show_err
fi
for bad in 'move 0 pos=1,2,3' 'frames 3 4' 'remove 1' 'click 10 10' 'key N' 'screenshot x.png' \
    'fly 0'; do
    printf 'light point pos=60,300,279 rgb=20000\nframes 1\n%s\n' "$bad" > "$T/bad.txt"
    run animate "$LTFILE" --lights "$T/bad.txt" -o "$T/frames"
    if [ "$rc" -eq 2 ] && grep -q "bad.txt' line 3" "$T/err"; then
        pass "animate: '$bad' is refused naming line 3"
    else
        fail "animate: '$bad': exit $rc: $(cat "$T/err")"
    fi
done
# In order: the automatic exposure is keyed on the first frame after 'exposure 0', so
# emitters switched on before it give the exposure of a script that had them on all along,
# not that of the first frame, drawn with them off.
printf 'light point pos=60,300,279 rgb=20000\nemitters %s\nframes 1\n' on > "$T/on.txt"
printf 'light point pos=60,300,279 rgb=20000\nemitters %s\nframes 1\n' off > "$T/off.txt"
printf 'light point pos=60,300,279 rgb=20000\nemitters off\nframes 1\nemitters on\nexposure 0\nframes 1\n' > "$T/both.txt"
x_on=""; x_off=""; x_both=""
run animate "$LTFILE" --lights "$T/on.txt" -o "$T/e1" --width 16 --height 16 && x_on=$(value exposure)
run animate "$LTFILE" --lights "$T/off.txt" -o "$T/e2" --width 16 --height 16 && x_off=$(value exposure)
run animate "$LTFILE" --lights "$T/both.txt" -o "$T/e3" --width 16 --height 16 && x_both=$(value exposure)
if [ -n "$x_on" ] && [ "$x_both" = "$x_on" ] && [ "$x_both" != "$x_off" ]; then
    pass "animate: statements run in order (exposure $x_both = emitters on, not $x_off)"
else
    fail "animate: exposures on '$x_on', off '$x_off', off then on '$x_both'"
fi
run animate "$LTFILE" -o "$T/frames"
expect_rc 2 "animate without --lights is rejected"
run solve "$LTFILE" --light 'lamp pos=1,2,3'
expect_rc 2 "--light with an unknown kind is rejected"
run solve "$LTFILE" --light 'point pos=1,2'
expect_rc 2 "--light with a two-component position is rejected"
run solve "$LTFILE" --no-scene-emission
expect_rc 2 "--no-scene-emission without --probe or --light is rejected"
run solve "$LTFILE" --light 'spot pos=0,0,0 dir=0,0,0'
expect_rc 1 "--light spot with a zero direction is an error"
if grep -q "direction" "$T/err"; then pass "the error names the field"; else fail "no field in: $(cat "$T/err")"; fi

finish
