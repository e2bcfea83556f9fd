#!/usr/bin/env bash
# Long fuzz runs: each target (all of them, or those named as arguments) until it has run
# FUZZ_RUNS inputs (10 million) or for FUZZ_MAX_SECONDS (an hour), whichever comes first, one
# after the other. Prints a line per target: executions, seconds, peak memory and whether
# libFuzzer stopped on a crash. FUZZ_SANITIZER picks cargo-fuzz's sanitizer (`address`, the
# default, as `tests/run.sh` builds the targets; `none` runs safe Rust two to four times
# faster, with panics, timeouts and memory limits still caught). Each run's log is kept in target/fuzz-long/TARGET.log and
# its corpus grows in the target's fuzz/corpus folder. Run from anywhere in the repository:
#
#     bash tests/fuzz-long.sh                  # every target, as docs/fuzzing.md records
#     bash tests/fuzz-long.sh nmea recording   # only these
set -euo pipefail
cd "$(dirname "$0")/.."

runs=${FUZZ_RUNS:-10000000}
max_seconds=${FUZZ_MAX_SECONDS:-3600}
sanitizer=${FUZZ_SANITIZER:-address}
log_dir=$PWD/target/fuzz-long
mkdir -p "$log_dir"

wanted() {
    [ $# -eq 1 ] && return 0
    local target=$1
    shift
    printf '%s\n' "$@" | grep -qx -- "$target"
}

printf 'target\texecutions\tseconds\tpeak_rss_mb\tresult (sanitizer: %s)\n' "$sanitizer"
status=0
for dir in protocol firmware/lib host; do
    targets=$(cd "$dir" && cargo +nightly fuzz list)
    built=false
    for target in $targets; do
        wanted "$target" "$@" || continue
        if ! $built; then
            (cd "$dir" && cargo +nightly fuzz build -s "$sanitizer" >/dev/null 2>&1)
            built=true
        fi
        log=$log_dir/$target.log
        start=$(date +%s)
        if (cd "$dir" && cargo +nightly fuzz run -s "$sanitizer" "$target" -- -runs="$runs" \
            -max_total_time="$max_seconds" -print_final_stats=1) >"$log" 2>&1; then
            result=ok
        else
            result="stopped: see $log"
            status=1
        fi
        seconds=$(($(date +%s) - start))
        executions=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
        peak_rss_mb=$(sed -n 's/^stat::peak_rss_mb: *//p' "$log" | tail -n 1)
        printf '%s\t%s\t%s\t%s\t%s\n' "$target" "${executions:-?}" "$seconds" \
            "${peak_rss_mb:-?}" "$result"
    done
done
exit $status
