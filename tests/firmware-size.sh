#!/usr/bin/env bash
# Prints flash and static RAM of board ELFs and fails if they exceed the budget
# (flash <= 64 KiB, static RAM <= 32 KiB).
set -euo pipefail
flash_budget=$((64 * 1024))
ram_budget=$((32 * 1024))
status=0
for elf in "$@"; do
    read -r text data bss _ < <(arm-none-eabi-size -B "$elf" | tail -n 1)
    flash=$((text + data))
    ram=$((data + bss))
    awk -v elf="$elf" -v f="$flash" -v r="$ram" \
        'BEGIN { printf "%s: flash %d B (%.1f KiB of 64), static RAM %d B (%.1f KiB of 32)\n", elf, f, f / 1024, r, r / 1024 }'
    if [ "$flash" -gt "$flash_budget" ] || [ "$ram" -gt "$ram_budget" ]; then
        echo "  over budget" >&2
        status=1
    fi
done
exit $status
