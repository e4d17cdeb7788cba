#!/usr/bin/env bash
# Renders every figure of the documentation again by the command printed next
# to it, and says whether the committed image is still what that command makes.
#
#   scripts/check-figures.sh [--write]
#
# The commands are read from README.md and docs/*.md: every
# `twinray render ... -o docs/images/NAME ...` in them, run with the output in
# a temporary directory and compared byte for byte (`cmp`) with
# docs/images/NAME. With --write, the images that differ are replaced.
# Inputs made by a script are made first (docs/images/leaves.py,
# docs/images/pbr_grid.py); $SPD (default ../shared/scenes/spd) holds the SPD
# scenes, models/ the fetched models (scripts/fetch-real-models.sh): a figure
# whose input is missing is skipped, and said so. The anaglyphs of
# docs/images/budget/ are made by `python3 bench/depth_budget.py --images`.
# Exit status 1 if a figure differs (without --write).
# Needs: a release build (target/release/twinray), python3.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
write=false
[[ ${1:-} == --write ]] && write=true
twinray=${TWINRAY:-$root/target/release/twinray}
[[ -x $twinray ]] || { echo "build first: cargo build --release" >&2; exit 2; }
export SPD=${SPD:-$root/../shared/scenes/spd}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# The inputs that scripts make, where the documents say they are.
python3 docs/images/leaves.py /tmp/leaves >/dev/null
python3 docs/images/pbr_grid.py docs/images/pbr-grid.gltf >/dev/null

differ=0
while IFS= read -r cmd; do
  name=$(sed -E 's/.*-o docs\/images\/([^ ]+).*/\1/' <<< "$cmd")
  # The command's words, $SPD expanded, the output moved to the temporary
  # directory and `twinray` replaced by the build.
  read -r -a words <<< "${cmd//\$SPD/$SPD}"
  words[0]=$twinray
  for i in "${!words[@]}"; do
    [[ ${words[$i]} == docs/images/"$name" ]] && words[i]=$tmp/$name
  done
  input=${words[2]}
  if [[ ! -e $input ]]; then
    printf '%-28s skipped: %s is missing\n' "$name" "$input"
    continue
  fi
  if ! "${words[@]}" -q 2>"$tmp/err"; then
    printf '%-28s FAILED: %s\n' "$name" "$(tail -1 "$tmp/err")"
    differ=1
    continue
  fi
  if cmp -s "$tmp/$name" "docs/images/$name"; then
    printf '%-28s identical\n' "$name"
  elif $write; then
    cp "$tmp/$name" "docs/images/$name"
    printf '%-28s written again\n' "$name"
  else
    printf '%-28s DIFFERS\n' "$name"
    differ=1
  fi
done < <(grep -rhoE 'twinray render [^`]*-o docs/images/[^` ]+[^`]*' README.md docs/*.md | sort -u)
exit "$differ"
