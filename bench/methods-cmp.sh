#!/usr/bin/env bash
# Do two builds compute the same views? Renders every view method and each
# of the paper's options with each binary (the exact default under each
# sampling, the reference, --fast under each sampling and on a scene with
# cut-outs, merged secondary rays, the safe and the paper's reprojection, a
# cut), as PFM (the floats themselves), on several scenes, and compares
# every view with `cmp`; a view that differs is measured with
# `twinray compare` (PSNR, largest difference) against the old one.
# For a change that must not move a pixel of any method.
#
# usage (from the project root):  bench/methods-cmp.sh OLD_BIN NEW_BIN [SCENE...]
# Default scenes: scenes/{example,shelf,deep}.nff, the glTF torus of the
# tests (cut-outs) and $SPD/{balls,gears,mount,tetra,tree}.nff (default
# ../shared/scenes/spd, skipped when missing).
set -uo pipefail
[[ $# -ge 2 ]] || { sed -n 2,15p "$0" >&2; exit 2; }
old=$1 new=$2
shift 2
SPD=${SPD:-../shared/scenes/spd}
scenes=("$@")
if [[ ${#scenes[@]} == 0 ]]; then
  scenes=(scenes/example.nff scenes/shelf.nff scenes/deep.nff
          crates/twinray/tests/data/models/gltf/torus.gltf)
  for s in balls gears mount tetra tree; do
    [[ -f $SPD/$s.nff ]] && scenes+=("$SPD/$s.nff")
  done
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
failed=0 same=0 differ=0
# NAME then the flags, one configuration a line.
configs=(
  "mono|--samples 1"
  "pair-centres|--stereo --samples 1"
  "pair-adaptive|--stereo"
  "pair-spd|--stereo --spd --size 96x72"
  "five-samples2|--views 5 --samples 2"
  "nine-centres|--views 9 --samples 1"
  "pair-independent|--stereo --samples 1 --method independent"
  "fast-centres|--stereo --samples 1 --fast"
  "fast-adaptive|--stereo --fast"
  "fast-spd|--stereo --spd --size 96x72 --fast"
  "fast-six-samples2|--views 6 --samples 2 --fast"
  "merge|--stereo --samples 1 --merge-secondary"
  "reproject-safe|--stereo --samples 1 --reproject"
  "reproject-paper|--stereo --samples 1 --reproject --reproject-mode paper"
  "reproject-threshold|--views 3 --samples 1 --reproject --reproject-threshold 0.5"
  "merge-reproject-adaptive|--views 4 --merge-secondary --reproject"
  "cut|--stereo --samples 1 --cut-parallax 0.5"
  "cut-merge-reproject|--stereo --cut-parallax 0.25 --merge-secondary --reproject"
)
for scene in "${scenes[@]}"; do
  base=$(basename "${scene%.*}")
  for c in "${configs[@]}"; do
    name=${c%%|*} flags=${c#*|}
    size=(--size 120x90)
    [[ $flags == *--size* ]] && size=()
    rig=()
    [[ $flags == *--stereo* || $flags == *--views* ]] && rig=(--interaxial 0.1)
    for which in a b; do
      bin=$old; [[ $which == b ]] && bin=$new
      mkdir -p "$tmp/$which/$base-$name"
      # shellcheck disable=SC2086
      "$bin" render "$scene" -o "$tmp/$which/$base-$name/v.pfm" "${size[@]}" \
        "${rig[@]}" $flags --threads 2 -q 2> "$tmp/err" \
        || { echo "FAILED ($which) $base $name: $(head -1 "$tmp/err")"; failed=1; }
    done
    for f in "$tmp/a/$base-$name"/*.pfm; do
      [[ -f $f ]] || continue
      g="$tmp/b/$base-$name/$(basename "$f")"
      if cmp -s "$f" "$g"; then
        same=$((same + 1))
      else
        differ=$((differ + 1))
        echo "differs: $base $name $(basename "$f"): $("$new" compare "$f" "$g" 2>&1)"
      fi
    done
  done
done
echo "$same views identical, $differ differ"
[[ $failed == 0 && $differ == 0 ]]
