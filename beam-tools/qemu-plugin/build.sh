#!/usr/bin/env bash
# Builds the tick_insns QEMU plugin (needs gcc): build.sh OUT.so
# Rebuilds only when the source is newer than OUT.so; prints OUT.so's path.
set -euo pipefail
src="$(cd "$(dirname "$0")" && pwd)/tick_insns.c"
out=${1:?usage: build.sh OUT.so}
if [ ! "$out" -nt "$src" ]; then
  gcc -shared -fPIC -O2 -Wall -Wextra -Werror -fvisibility=hidden -o "$out" "$src"
fi
echo "$out"
