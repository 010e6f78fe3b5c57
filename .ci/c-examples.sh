#!/usr/bin/env bash
# Builds the C/C++ examples (examples/c, examples/cpp) with the system compiler against the
# release static library of penumbra-capi, into target/c-examples/. With --run, also runs them
# on the demo bake's outputs (out/demo/, from `cargo run --release -- bake bake-configs/demo.toml`)
# and fails if any of them fails. `make c-examples` = this script without --run.
set -euo pipefail
cd "$(dirname "$0")/.."
CC=${CC:-cc}
CXX=${CXX:-c++}
out=target/c-examples
flags=(-Wall -Wextra -Werror -pedantic -O2 -Iinclude -Iexamples/c)
libs=(target/release/libpenumbra_capi.a -lpthread -ldl -lm)

cargo build --release --quiet -p penumbra-capi
mkdir -p "$out"
"$CC" -std=c99 "${flags[@]}" examples/c/inspect.c -o "$out/inspect"
"$CC" -std=c99 "${flags[@]}" examples/c/shade_fiv.c "${libs[@]}" -o "$out/shade_fiv"
if command -v "$CXX" >/dev/null 2>&1; then
  "$CXX" -std=c++17 "${flags[@]}" examples/cpp/mrt_level.cpp "${libs[@]}" -o "$out/mrt_level"
else
  echo "no C++ compiler '$CXX' (install g++): examples/cpp/mrt_level.cpp skipped" >&2
  rm -f "$out/mrt_level"
fi
echo "built the examples in $out"

if [ "${1:-}" = "--run" ]; then
  d=out/demo
  "$out/inspect" "$d/tables.shtb" "$d/character.sphr" "$d/torus.fivt" "$d/dictionary.mrtd" "$d/level.mrtl" > /dev/null
  "$out/shade_fiv" "$d/torus.fivt" > /dev/null
  if [ -x "$out/mrt_level" ]; then "$out/mrt_level" "$d/dictionary.mrtd" "$d/level.mrtl" > /dev/null; fi
  echo "C/C++ examples ran on $d"
fi
