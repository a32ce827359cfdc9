#!/usr/bin/env bash
# Run the whole test suite. Sets up everything it needs first (Embree 4 and libclang on machines
# whose OS lacks them; see scripts/setup-embree.sh). Extra arguments go to `cargo test`.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup-embree.sh >/dev/null
if ! command -v cc >/dev/null || ! command -v valgrind >/dev/null || ! command -v cmake >/dev/null ||
   ! command -v pkg-config >/dev/null; then
  if command -v apt-get >/dev/null; then
    echo "test.sh: installing a C compiler, valgrind, cmake and pkg-config (for the C API tests)" >&2
    if [ "$(id -u)" = 0 ]; then sudo=""; else sudo=sudo; fi
    $sudo apt-get update -qq >&2 &&
      DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq gcc valgrind cmake pkg-config >&2
  fi
fi
cargo build --release --workspace --quiet
exec cargo test --release --workspace "$@"
