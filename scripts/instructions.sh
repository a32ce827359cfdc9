#!/usr/bin/env bash
# Instructions per ray and per patch test, counted by callgrind (repeatable where wall times are
# not): the bench's primary rays and the shadow rays of its shaded render (256², 1 thread, one
# patch per primitive), through Embree on the Phong mesh against its flat triangles, and each
# outcome of the patch solve replayed alone; then the same rays in the renderer's 8-ray packets
# (4x2 pixel blocks), the lanes tested together and one by one. Only `counted_work` (or
# `counted_packets`) is collected (set-up excluded).
#
#   scripts/instructions.sh [SCENE...]     SCENE: sphere-120 (default) or an OBJ file
#
# Prints Markdown tables per scene: instructions per ray and per test by outcome, then the tests
# of the patch each shadow ray starts on, by the outcome of their full solve, and how many of
# them the origin skip settles without a solve (counted directly, not under callgrind). Needs
# valgrind.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v valgrind >/dev/null || { echo "instructions.sh: valgrind is not installed" >&2; exit 1; }
cargo build --release --quiet --example instructions
bin=${CARGO_TARGET_DIR:-target}/release/examples/instructions
[ $# -gt 0 ] || set -- sphere-120

# count SCENE KIND WHAT: prints "items instructions".
count() {
    local log out n ir
    log=$(mktemp)
    out=$(valgrind --tool=callgrind --callgrind-out-file=/dev/null --collect-atstart=no \
        --toggle-collect='*counted_work*' --toggle-collect='*counted_packets*' "$bin" "$@" 2>"$log") || { cat "$log" >&2; rm -f "$log"; exit 1; }
    n=$out
    ir=$(sed -n 's/.*Collected : \([0-9]*\).*/\1/p' "$log")
    rm -f "$log"
    echo "$n $ir"
}

outcomes="hull-reject net-miss certified-hit certified-miss analytic-hit analytic-miss f64-retry bad-input"
for scene in "$@"; do
    echo "## $scene"
    echo
    echo "| rays | phong instr/ray | flat instr/ray | phong / flat | patch tests per ray |"
    echo "|---|---|---|---|---|"
    rows=""
    for kind in primary shadow; do
        read -r rays phong <<<"$(count "$scene" "$kind" phong)"
        read -r _ flat <<<"$(count "$scene" "$kind" flat)"
        tests=0
        for o in $outcomes; do
            read -r n ir <<<"$(count "$scene" "$kind" "$o")"
            [ "$n" -gt 0 ] || continue
            tests=$((tests + n))
            rows+="| $kind | ${o//-/ } | $n | $(awk -v a="$n" -v b="$rays" 'BEGIN{printf "%.3f", a/b}') | $((ir / n)) |"$'\n'
        done
        awk -v k="$kind" -v p="$phong" -v f="$flat" -v r="$rays" -v t="$tests" \
            'BEGIN{printf "| %s | %d | %d | %.2f | %.3f |\n", k, p/r, f/r, p/f, t/r}'
    done
    echo
    echo "| rays, 8-ray packets | phong instr/ray | lane by lane | flat instr/ray | phong / flat |"
    echo "|---|---|---|---|---|"
    for kind in primary shadow; do
        read -r rays phong <<<"$(count "$scene" "$kind" phong-packets)"
        read -r _ lanes <<<"$(count "$scene" "$kind" phong-packets-lane-by-lane)"
        read -r _ flat <<<"$(count "$scene" "$kind" flat-packets)"
        awk -v k="$kind" -v p="$phong" -v l="$lanes" -v f="$flat" -v r="$rays" \
            'BEGIN{printf "| %s | %d | %d | %d | %.2f |\n", k, p/r, l/r, f/r, p/f}'
    done
    echo
    echo "| rays | outcome | tests | per ray | instr/test |"
    echo "|---|---|---|---|---|"
    printf '%s' "$rows"
    echo
    # The origin tests: "rays" last (the example prints it after the outcomes).
    echo "Origin tests per shadow ray (the patch each shadow ray starts on), by the outcome of its full solve:"
    echo
    echo "| outcome | origin tests per ray | settled without a solve | still solved per ray |"
    echo "|---|---|---|---|"
    out=$("$bin" "$scene" shadow origin)
    rays=$(tail -n 1 <<<"$out")
    head -n -1 <<<"$out" | awk -v r="$rays" '{t+=$2; s+=$3; printf "| %s | %.3f | %.3f | %.3f |\n", $1, $2/r, $3/r, ($2-$3)/r}
        END {printf "| all | %.3f | %.3f | %.3f |\n", t/r, s/r, (t-s)/r}' | sed 's/-/ /g'
    echo
done
