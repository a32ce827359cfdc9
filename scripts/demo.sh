#!/usr/bin/env bash
# Render the demo scene (the paper's Figure 1: a low-poly sphere on a ground plane, flat against Phong) to
# sphere.png. Sets up everything it needs first (see scripts/setup-embree.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup-embree.sh >/dev/null
cargo build --release --quiet
exec target/release/phongrt render scenes/sphere_lowpoly.obj --compare --ground --width 360 --height 360 --spp 4 -o "${1:-sphere.png}"
