#!/bin/sh
# make fuzz-smoke: runs each libFuzzer target for FUZZ_SECONDS (default 60) on a fresh copy of
# its seeds, FUZZ_JOBS (default 2) targets at a time, and prints per target the executions,
# exec/s and final coverage (cov: edges, ft: features). Fails if any target found a crash,
# leak, timeout or out-of-memory (the input is saved as OUT/TARGET/crash-* etc.; reproduce it
# with tests/fuzz/replay_TARGET FILE, then add it to tests/fuzz/TARGET/regressions).
#
# FUZZ_SEED (default 1) fixes libFuzzer's seed, so a CI run mostly repeats the mutations a
# longer `make fuzz-smoke FUZZ_SECONDS=N` made here (not exactly: libFuzzer orders the seed
# files by size only, and equal sizes come in the file system's order): the smoke is a
# regression gate, not the place where new bugs are expected. FUZZ_SEED=0 draws a new seed
# each run (exploration, long runs).
#
#   smoke.sh SRC_FUZZ_DIR BIN_DIR OUT_DIR TARGET...
set -u
src=$1 bin=$2 out=$3
shift 3
seconds=${FUZZ_SECONDS:-60}
jobs=${FUZZ_JOBS:-2}
seed=${FUZZ_SEED:-1}
case $seconds in '' | *[!0-9]*) echo "fuzz-smoke: FUZZ_SECONDS='$seconds' is not a number" >&2; exit 2 ;; esac
case $seed in '' | *[!0-9]*) echo "fuzz-smoke: FUZZ_SEED='$seed' is not a number" >&2; exit 2 ;; esac
case $jobs in '' | *[!0-9]* | 0) echo "fuzz-smoke: FUZZ_JOBS='$jobs' is not a positive number" >&2; exit 2 ;; esac

# ASan: report leaks (but those of third-party libraries in tests/lsan.supp); libFuzzer: -timeout per input, -rss_limit_mb for the process,
# -malloc_limit_mb for one allocation (a loader that allocates what a corrupted header claims
# is a finding). -close_fd_mask=1: nothing a target prints on stdout matters; stderr keeps
# the targets' own findings (fuzz_fail) next to libFuzzer's and the sanitizers' reports.
ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1}
LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$src/../lsan.supp}
UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}
OMP_NUM_THREADS=1
export ASAN_OPTIONS LSAN_OPTIONS UBSAN_OPTIONS OMP_NUM_THREADS

run_one() {
    t=$1
    dir=$out/$t
    rm -rf "$dir"
    mkdir -p "$dir/corpus" || return 1
    cp "$src/$t/seeds/"* "$dir/corpus/" || return 1
    # the regressions too: libFuzzer runs the corpus first, under its allocation limit, so a
    # loader that again allocates what a corrupted header claims fails here (the gcc replay
    # in make check cannot see an allocation that merely fails)
    if [ -d "$src/$t/regressions" ]; then
        for f in "$src/$t/regressions/"*; do
            [ -f "$f" ] && cp "$f" "$dir/corpus/"
        done
    fi
    "$bin/fuzz_$t" -max_total_time="$seconds" -seed="$seed" -print_final_stats=1 -timeout=25 \
        -rss_limit_mb=2048 -malloc_limit_mb=1024 -close_fd_mask=1 \
        -dict="$src/$t/$t.dict" -artifact_prefix="$dir/" "$dir/corpus" > "$dir/log" 2>&1
    echo $? > "$dir/rc"
}

# Runs the targets FUZZ_JOBS at a time.
targets="$*"
while [ $# -gt 0 ]; do
    batch=0
    while [ $# -gt 0 ] && [ "$batch" -lt "$jobs" ]; do
        run_one "$1" &
        shift
        batch=$((batch + 1))
    done
    wait
done

failed=0
for t in $targets; do
    dir=$out/$t
    rc=$(cat "$dir/rc" 2>/dev/null || echo 1)
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$dir/log" | tail -n 1)
    speed=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$dir/log" | tail -n 1)
    last=$(grep -E '^#[0-9]+' "$dir/log" | grep 'cov:' | tail -n 1)
    cov=$(echo "$last" | sed -n 's/.* cov: \([0-9]*\).*/\1/p')
    ft=$(echo "$last" | sed -n 's/.* ft: \([0-9]*\).*/\1/p')
    corp=$(echo "$last" | sed -n 's/.* corp: \([0-9]*\).*/\1/p')
    found=$(ls "$dir" | grep -E '^(crash|leak|timeout|oom)-' | tr '\n' ' ')
    status=ok
    if [ "$rc" -ne 0 ] || [ -n "$found" ]; then
        status=FAILED
        failed=$((failed + 1))
    fi
    printf 'fuzz %-9s %s: %s executions, %s exec/s, cov %s, ft %s, corpus %s (%ss, seed %s)\n' \
        "$t" "$status" "${execs:-?}" "${speed:-?}" "${cov:-?}" "${ft:-?}" "${corp:-?}" "$seconds" \
        "$seed"
    if [ "$status" = FAILED ]; then
        [ -n "$found" ] && echo "  found: $found(in $dir)"
        grep -E 'ERROR|SUMMARY|fuzz target:|runtime error|==[0-9]+==' "$dir/log" | head -n 20 | sed 's/^/  /'
    fi
done
[ "$failed" -eq 0 ] && echo "fuzz-smoke: all targets ran ${seconds}s without a finding"
[ "$failed" -eq 0 ]
