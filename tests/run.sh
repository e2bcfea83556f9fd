#!/usr/bin/env bash
# The project's test command: formatting, lints, every test, the fuzz targets, and the board
# firmware cross-built in release with its size. Run from anywhere in the repository.
set -euo pipefail
cd "$(dirname "$0")/.."

step() { printf '\n==> %s\n' "$*"; }

# Crates with their own workspace: the board binaries and the fuzz targets.
separate=(firmware/board firmware/qemu protocol/fuzz firmware/lib/fuzz host/fuzz)

step "cargo fmt --check"
cargo fmt --all --check
for dir in "${separate[@]}"; do
    cargo fmt --check --manifest-path "$dir/Cargo.toml"
done

step "cargo clippy (workspace, all targets, -D warnings)"
cargo clippy --workspace --all-targets -- -D warnings

step "QEMU image: release build for thumbv7em-none-eabihf (tests/qemu_chain.rs boots it)"
(
    cd firmware/qemu
    cargo clippy --release -- -D warnings
    cargo build --release
)

step "cargo test --workspace"
cargo test --workspace

step "fuzz targets: build, then a short run of each"
# Unoptimised (`--dev`, still with the sanitizer and debug assertions): a short run needs no
# speed, and the host's targets build in about half the time. The long runs (tests/fuzz-long.sh)
# use optimised builds.
for dir in protocol firmware/lib host; do
    (cd "$dir" && cargo +nightly fuzz build --dev)
    for target in $(cd "$dir" && cargo +nightly fuzz list); do
        (cd "$dir" && cargo +nightly fuzz run --dev "$target" -- -max_total_time="${FUZZ_SECONDS:-15}" \
            2>&1 | tail -n 1)
    done
done

step "board firmware: release build for thumbv7em-none-eabihf (USB link and UART link)"
(
    cd firmware/board
    cargo clippy --release -- -D warnings
    cargo build --release
    cargo build --release --no-default-features --features uart-link --target-dir target/uart-link
)
elf=firmware/board/target/thumbv7em-none-eabihf/release/sensor-board
elf_uart=firmware/board/target/uart-link/thumbv7em-none-eabihf/release/sensor-board
bash tests/firmware-size.sh "$elf" "$elf_uart"

step "instructions per B0 telegram (callgrind)"
bash tests/sick-instructions.sh

echo
echo "all checks passed"
