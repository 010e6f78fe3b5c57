#!/usr/bin/env bash
# Layering (DESIGN §1): penumbra-asset depends on nothing but bytemuck; penumbra-runtime
# on penumbra-asset (and bytemuck) only; penumbra-capi (the C ABI) on those two only.
# Checks normal (non-dev) dependencies.
set -euo pipefail
cd "$(dirname "$0")/.."
fail=0
check() {
  local pkg=$1; shift
  local allowed=" $* "
  local deps
  deps=$(cargo tree -p "$pkg" -e normal --prefix none --format '{p}' | awk '{print $1}' | sort -u)
  for d in $deps; do
    if [[ "$allowed" != *" $d "* ]]; then
      echo "layering violation: $pkg depends on $d (allowed: $*)" >&2
      fail=1
    fi
  done
}
check penumbra-asset penumbra-asset bytemuck
check penumbra-runtime penumbra-runtime penumbra-asset bytemuck
check penumbra-capi penumbra-capi penumbra-runtime penumbra-asset bytemuck
if [ "$fail" -ne 0 ]; then exit 1; fi
echo "dependency layering ok"
