#!/bin/sh
# The one option parser of solve, render, export and animate (cli_parse_command): the same
# message for the same mistake in each command, exit 2.
. "$(dirname "$0")/harness.sh"

small_lrr

# One parser reads the options of solve, render, export and animate (cli_parse_command): an
# unknown option, a missing value and a bad number get the same message in each, exit 2.
# usage_error CMD WANT ARGS...: lrr CMD ARGS exits 2 with "lrr CMD: WANT" on stderr
usage_error() {
    cmd=$1 want=$2
    shift 2
    run "$cmd" "$LRRFILE" "$@"
    if [ "$rc" -eq 2 ] && grep -qF -- "lrr $cmd: $want" "$T/err" && [ ! -s "$T/out" ]; then
        pass "$cmd $*: exit 2, $want"
    else
        fail "$cmd $*: exit $rc, expected 2 and 'lrr $cmd: $want': $(cat "$T/err")"
    fi
}
for o in "solve --repeat" "render --width" "export --format" "animate --fov"; do
    cmd=${o% *} o=${o#* }
    usage_error $cmd "unknown option '--bogus'" --bogus
    usage_error $cmd "unknown option '-x'" -x
    usage_error $cmd "$o: a value is required" $o
done
usage_error animate "unknown option '--emission-scale'" --emission-scale 2 # no emission here
set --
while [ $# -lt 34 ]; do set -- "$@" --light 'sun dir=0,1,0 rgb=1'; done
for o in "solve --repeat=1" "render -o$T/u.png" "export -o$T/u.glb"; do
    cmd=${o%% *} o=${o#* }
    usage_error $cmd "--emission-scale: a value is required" $o --emission-scale
    usage_error $cmd "--emission-scale: 'abc' is not a number" $o --emission-scale abc
    usage_error $cmd "--emission-scale: '-1' is out of range" $o --emission-scale=-1
    usage_error $cmd "--sources, --probe-method and --probe-scale need --probe" $o --probe-scale 2
    usage_error $cmd "--light: at most 16 lights" $o "$@" # 17 of them
done
for cmd in render animate; do
    usage_error $cmd "--width: '0' is out of range (1..16384)" --width 0
    usage_error $cmd "--fov: '180' is out of range (it must be less than 180)" --fov 180
    usage_error $cmd "--camera: 'nope' is not one of cornell, fit, auto" --camera nope
done
usage_error solve "--repeat: '1x' is not an integer" --repeat 1x
usage_error solve "--csv: the file name is empty" --csv ''
usage_error export "--exposure: '0' is out of range (it must be greater than 0)" -o "$T/u.glb" \
    --exposure 0
usage_error export "--format: 'obj' is not one of gltf, ply" -o "$T/u.glb" --format obj
usage_error animate "--format: 'tiff' is not one of png, exr" --format tiff
# a required option left out: the same message and hint in each command
usage_error render "-o OUT.png (or OUT.exr) is required" --width 8
usage_error export "-o OUT.glb (or OUT.ply) is required" --subpatches
usage_error animate "--lights SCRIPT is required" -o "$T/u"
usage_error animate "-o DIR is required" --lights "$T/u.txt"
if grep -qF "Try 'lrr animate --help'." "$T/err"; then
    pass "animate: a required option left out suggests --help, as render's and export's do"
else
    fail "animate: no --help hint in: $(cat "$T/err")"
fi


finish
