#!/usr/bin/env bash
# Long fuzz runs: each target (all of them, or those named as arguments) until it has run
# FUZZ_RUNS inputs (10 million) or for FUZZ_MAX_SECONDS (an hour), whichever comes first, one
# after the other. Prints a line per target: executions, seconds, peak memory and whether
# libFuzzer stopped on a crash. Each run's log is kept in target/fuzz-long/TARGET.log and
# its corpus grows in the target's fuzz/corpus folder.
#
# FUZZ_SANITIZER picks cargo-fuzz's sanitizer: `address` (the default, as tests/run.sh builds
# the targets) or `none`, which runs safe Rust two to four times faster and still stops on
# panics, timeouts and a resident memory over the limit, but not on a single oversized
# allocation (libFuzzer's -malloc_limit_mb needs the sanitizer's hooks). Run from anywhere in
# the repository:
#
#     bash tests/fuzz-long.sh                         # every target
#     bash tests/fuzz-long.sh nmea_parser recording   # only these
set -euo pipefail
cd "$(dirname "$0")/.."

runs=${FUZZ_RUNS:-10000000}
max_seconds=${FUZZ_MAX_SECONDS:-3600}
sanitizer=${FUZZ_SANITIZER:-address}
log_dir=$PWD/target/fuzz-long
mkdir -p "$log_dir"

# Whether the target $1 is among the names asked for (all when none was).
wanted() {
    local target=$1 name
    shift
    [ $# -eq 0 ] && return 0
    for name; do
        [ "$name" = "$target" ] && return 0
    done
    return 1
}

printf 'target\texecutions\tseconds\tpeak_rss_mb\tresult (sanitizer: %s)\n' "$sanitizer"
status=0
found=()
for dir in protocol firmware/lib host; do
    targets=$(cd "$dir" && cargo +nightly fuzz list)
    built=false
    for target in $targets; do
        wanted "$target" "$@" || continue
        found+=("$target")
        if ! $built; then
            build_log=$log_dir/build-${dir//\//-}.log
            if ! (cd "$dir" && cargo +nightly fuzz build -s "$sanitizer") >"$build_log" 2>&1; then
                printf '%s\t-\t-\t-\tnot built: see %s\n' "$target" "$build_log"
                status=1
                break
            fi
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
for name; do
    if ! wanted "$name" "${found[@]+"${found[@]}"}" || [ ${#found[@]} -eq 0 ]; then
        echo "no fuzz target named $name (cargo +nightly fuzz list in protocol, firmware/lib, host)" >&2
        status=1
    fi
done
exit $status
