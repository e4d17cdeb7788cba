#!/usr/bin/env bash
# One descent for N views (issue 16): the strip eye pass (--strip) against the
# twin method's batches of 4 views (the default) and of 8 (--views-per-batch 8),
# exact, N views at SIZE, one ray per pixel centre. For each scene, N and mode:
# CPU seconds of the whole command (user + sys, so that other work on a shared
# machine does not count), that ÷ one mono view's, the eye pass's seconds
# (--stats eye_pass_cpu_s, wall time summed over threads), the eye-ray descents,
# and the strip's counters: nodes per descent, single-ray primitive tests per
# eye ray, primitives it could not bound. Every strip view is compared with the
# batches' view (must be identical: max_abs 0). ROUNDS rounds, interleaved
# (mono, b4, b8, strip, runs, mono, ...); the CSV keeps every round.
# MODES (default "b4 b8 strip runs"; b4 must come first): runs is the eye runs
# (--eye-runs), with their counters: rays traced alone and filled by a proof
# per eye ray, the proofs per family and the share of them that failed.
#
# usage (from the project root, after cargo build --release):
#   bench/strip.sh [SIZE] [VIEWS] [INTERAXIAL] [CSV] [SCENE...]
#   defaults: SIZE=420x560  VIEWS=16,48  INTERAXIAL=0.02
#             CSV=docs/strip-bench.csv  SCENES=tree balls mount tetra (../shared)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
size=${1:-420x560}
counts=${2:-16,48}
b=${3:-0.02}
csv=${4:-docs/strip-bench.csv}
shift $(( $# > 4 ? 4 : $# )) || true
spd=${SPD:-../shared/scenes/spd}
scenes=("$@")
if [[ ${#scenes[@]} -eq 0 ]]; then
  for n in tree balls mount tetra; do scenes+=("$spd/$n.nff"); done
fi
bin=${TWINRAY:-target/release/twinray}
threads=${THREADS:-1}
rounds=${ROUNDS:-1}
modes=${MODES:-b4 b8 strip runs}
[[ -x $bin ]] || { echo "build first: cargo build --release" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
common=(--size "$size" --samples 1 -q --threads "$threads")

cpu() { /usr/bin/time -f "%U %S" -o "$tmp/time" "$@"; read -r u s < "$tmp/time"; python3 -c "print($u + $s)"; }
stats() {
  python3 - "$1" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
s = d.get("strip", {})
r = d.get("eye_runs", {})
eye = d["rays"]["eye"] or 1
desc = s.get("descents", 0)
fam = r.get("families", 0)
print(",".join(str(x) for x in [
    d["time"].get("eye_pass_cpu_s") or 0, d["eye_traversals"],
    round(s.get("nodes", 0) / desc, 1) if desc else "",
    round(s.get("exact_tests", 0) / eye, 2) if desc else "",
    s.get("unbounded", 0),
    round(r.get("traced", 0) / eye, 3) if fam else "",
    round(r.get("filled", 0) / eye, 3) if fam else "",
    round(r.get("proofs", 0) / fam, 2) if fam else "",
    round(r.get("proofs_failed", 0) / max(r.get("proofs", 0), 1), 3) if fam else "",
    round(r.get("proof_nodes", 0) / max(r.get("proofs", 0), 1), 1) if fam else ""]))
EOF
}

echo "scene,size,views,mode,round,cpu_s,per_mono,eye_pass_s,eye_descents,strip_nodes_per_descent,strip_prim_tests_per_eye_ray,strip_unbounded,runs_traced_per_eye_ray,runs_filled_per_eye_ray,runs_proofs_per_family,runs_proofs_failed_share,runs_nodes_per_proof,max_abs_vs_b4" > "$csv"
for scene in "${scenes[@]}"; do
  name=$(basename "$scene" .nff)
  for n in ${counts//,/ }; do
    for r in $(seq 1 "$rounds"); do
      mono=$(cpu "$bin" render "$scene" -o "$tmp/mono.pfm" "${common[@]}" --stats "$tmp/mono.json")
      echo "$name,$size,1,mono,$r,$mono,1,$(stats "$tmp/mono.json"),0" >> "$csv"
      for mode in $modes; do
        extra=()
        [[ $mode == b8 ]] && extra=(--views-per-batch 8)
        [[ $mode == strip ]] && extra=(--strip)
        [[ $mode == runs ]] && extra=(--eye-runs)
        rm -f "$tmp/$mode"_*.pfm
        s=$(cpu "$bin" render "$scene" -o "$tmp/$mode.pfm" "${common[@]}" --views "$n" \
          --interaxial "$b" "${extra[@]}" --stats "$tmp/$mode.json")
        maxabs=0
        if [[ $mode != b4 ]]; then
          maxabs=$(for f in "$tmp"/b4_*.pfm; do "$bin" compare "$f" "$tmp/${mode}_${f#"$tmp"/b4_}"; done \
            | sed 's/.*max_abs \([^ ]*\).*/\1/' | sort -g | tail -1)
        fi
        ratio=$(python3 -c "print(f'{$s / $mono:.2f}')")
        echo "$name,$size,$n,$mode,$r,$s,$ratio,$(stats "$tmp/$mode.json"),$maxabs" >> "$csv"
        echo "$name N=$n $mode round $r: ${s}s CPU, ${ratio}x mono, max_abs vs b4 $maxabs" >&2
      done
    done
  done
done
