#!/usr/bin/env bash
# Instructions the firmware library spends on one 732-byte B0 telegram (receiver + scan
# parse), counted by callgrind: the difference between 1000 parses and none, divided by 1000.
# Budget: 20 000 instructions per telegram.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p firmware --example parse_b0_callgrind
bin=target/release/examples/parse_b0_callgrind
count() {
    valgrind --tool=callgrind --callgrind-out-file=/dev/null "$bin" "$1" 2>&1 |
        awk '/Collected :/ { print $NF }'
}
base=$(count 0)
full=$(count 1000)
per=$(( (full - base) / 1000 ))
echo "B0 telegram (732 bytes): $per instructions per telegram (callgrind; budget 20000)"
[ "$per" -le 20000 ]
