#!/usr/bin/env bash
# Fuzz the asset loader (target `loader`) for a bounded time.
#   bash fuzz/run.sh [SECONDS]      (default 60; `make fuzz` passes FUZZ_SECONDS)
#
# cargo-fuzz drives libFuzzer and passes nightly-only rustc flags (-Zsanitizer=address, ...).
# No nightly toolchain is needed: RUSTC_BOOTSTRAP=1 lets the stable compiler accept them, and the
# AddressSanitizer runtime ships with the stable x86_64-unknown-linux-gnu standard library.
# Findings go to fuzz/artifacts/loader/ (reproduce with `RUSTC_BOOTSTRAP=1 cargo fuzz run loader FILE`);
# the corpus grows in fuzz/corpus/loader/ (both ignored by git).
set -euo pipefail
cd "$(dirname "$0")/.."

secs="${1:-60}"
case "$secs" in
  '' | *[!0-9]*) echo "usage: $0 [SECONDS]   (a whole number of seconds, got '$secs')" >&2; exit 2 ;;
esac

if ! cargo fuzz --version >/dev/null 2>&1; then
  echo "== installing cargo-fuzz" >&2
  cargo install cargo-fuzz --locked
fi

corpus=fuzz/corpus/loader
mkdir -p "$corpus"
if [ -z "$(ls -A "$corpus")" ]; then
  echo "== seeding $corpus with valid assets" >&2
  cargo run --quiet -p penumbra-asset --example fuzz_seeds -- "$corpus"
fi

echo "== fuzzing the loader for ${secs}s" >&2
RUSTC_BOOTSTRAP=1 cargo fuzz run loader "$corpus" -- -max_total_time="$secs" -max_len=65536
