#!/usr/bin/env bash
# Fuzz the single-header C reader (fuzz/c/asset_reader.c) with libFuzzer for a bounded time.
#   bash fuzz/run-c.sh [SECONDS]      (default 60; `make fuzz-c` passes FUZZ_SECONDS)
# Needs clang (installed from Debian's packages when absent: apt-get update + install clang).
# Seeds: the compat corpus and the loader fuzzer's seeds; the corpus grows in
# fuzz/corpus/c_reader/ and findings go to fuzz/artifacts/c_reader/ (both ignored by git).
set -euo pipefail
cd "$(dirname "$0")/.."
secs="${1:-60}"
case "$secs" in
  '' | *[!0-9]*) echo "usage: $0 [SECONDS]   (a whole number of seconds, got '$secs')" >&2; exit 2 ;;
esac
if ! command -v clang >/dev/null 2>&1; then
  echo "== installing clang" >&2
  sudo=""; if [ "$(id -u)" -ne 0 ]; then sudo="sudo -n"; fi
  $sudo apt-get update -qq && $sudo apt-get install -y -qq clang >/dev/null
fi
corpus=fuzz/corpus/c_reader
mkdir -p "$corpus" fuzz/artifacts/c_reader target
if [ -z "$(ls -A "$corpus")" ]; then
  echo "== seeding $corpus" >&2
  cargo run --quiet -p penumbra-asset --example fuzz_seeds -- "$corpus"
  cp tests/assets/v1/*.sphr tests/assets/v1/*.mrtl "$corpus"/
fi
clang -std=c99 -g -O1 -Wall -Wextra -Werror -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
  -Iinclude fuzz/c/asset_reader.c -o target/fuzz_c_reader
echo "== fuzzing the C reader for ${secs}s" >&2
target/fuzz_c_reader "$corpus" -max_total_time="$secs" -max_len=65536 -artifact_prefix=fuzz/artifacts/c_reader/
