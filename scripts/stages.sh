#!/usr/bin/env bash
# Where a ray's instructions go, stage by stage: the work scripts/instructions.sh counts (the
# bench's rays, 256², 1 thread), under callgrind with a cost per instruction, each instruction
# charged to the innermost stage function it was compiled into. Most stages are inlined into
# their callers; addr2line resolves the inlined frames from line tables, built into a target
# directory of their own (target/stages, the release profile otherwise unchanged: the same
# instruction counts as the release build).
#
#   scripts/stages.sh SCENE primary|shadow WHAT [STAGE,STAGE,...]
#
# SCENE: sphere-120 or an OBJ file. WHAT: phong, phong-packets, flat or flat-packets (per ray),
# or a patch-test outcome such as certified-hit or analytic-miss (its solves replayed alone, per
# test). STAGE: function names (the last path segment; a multiversioned function under its own
# name); the default list covers the callback route, the origin rules, the packet kernel and the
# scalar solve's stages. Prints a Markdown table; instructions in no stage are listed as
# "(other) F", F the innermost of the project's own functions there, and those of Embree or libc
# under the library's name. Needs valgrind, python3 and addr2line (binutils).
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 3 ] || { echo "usage: scripts/stages.sh SCENE primary|shadow WHAT [STAGE,...]" >&2; exit 2; }
for tool in valgrind python3 addr2line; do
    command -v $tool >/dev/null || { echo "stages.sh: $tool is not installed" >&2; exit 1; }
done
stages=${4:-intersect_callback,occluded_callback,intersect_packet_callback,occluded_packet_callback,\
intersect_packet_callback_v3,occluded_packet_callback_v3,\
offer_hits,origin_in,intersect_primitive_from,intersect_lanes,prim_hit,\
leaves_origin,leaves_patch_by,leaves_convex,leaves_unfolded,unfolded_or_bounded,\
hull_lanes,project_lanes,proof_lanes,certified_root,solve_lanes,member_lanes,roots_lanes,unsure_answer,refused_dispatched,\
to_local,hull_f32_v3,hits_hull,project,first_proof,newton_root,certified_newton,\
line_pair_root,split_line_pair,line_conic,nearest_polished,lean,lean_member,lean_roots,analytic_from_member,full_search,decide_in_f64}
dir=${CARGO_TARGET_DIR:-target}/stages
CARGO_PROFILE_RELEASE_DEBUG=line-tables-only CARGO_TARGET_DIR=$dir \
    cargo build --release --quiet --example instructions
bin=$dir/release/examples/instructions
out=$(mktemp)
log=$(mktemp)
trap 'rm -f "$out" "$log"' EXIT
items=$(valgrind --tool=callgrind --callgrind-out-file="$out" --dump-instr=yes --collect-atstart=no \
    --toggle-collect='*counted_work*' --toggle-collect='*counted_packets*' "$bin" "$1" "$2" "$3" 2>"$log") \
    || { cat "$log" >&2; exit 1; }
echo "$1, $2 rays, $3: $items items, $(sed -n 's/.*Collected : \([0-9]*\).*/\1/p' "$log") instructions"
echo
python3 scripts/stages.py "$out" "$bin" "$items" "$stages"
