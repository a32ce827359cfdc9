#!/usr/bin/env bash
# The user-geometry floor without our Rust code: compile benches/c/user_floor.c (Embree's
# user_geometry tutorial's callback with a triangle test) against the same Embree 4 the crate uses,
# and run it. Arguments go to the program: [segments rings [width]], defaults 12 6 128, the scene of
# `cargo bench --bench primary_rays`.
set -euo pipefail
cd "$(dirname "$0")/.."
dir="$(scripts/setup-embree.sh | tail -n1)"
flags=()
if [ "$dir" != system ]; then
  flags=(-I"$dir/include" -L"$dir/lib" -Wl,-rpath,"$dir/lib")
fi
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
"${CC:-cc}" -std=c99 -O2 -Wall -Wextra -Werror -o "$out/user_floor" benches/c/user_floor.c "${flags[@]}" -lembree4 -lm
"$out/user_floor" "$@"
