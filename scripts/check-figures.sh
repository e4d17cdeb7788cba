#!/usr/bin/env bash
# Runs the README's examples as written, and renders every figure of the
# documentation again by the command printed next to it, and says whether the
# committed image is still what that command makes.
#
#   scripts/check-figures.sh [--write | --readme]
#
# The README's examples: every line of its ```sh blocks that starts with
# `twinray ` (not `twinray preview`, a server, nor a figure's command), run in
# order in a temporary directory that sees the repository's scenes/, each
# with the build for `twinray`. An example that fails, or prints a warning,
# fails the check. --readme runs only these (CI does, .ci/run).
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
write=false readme_only=false
[[ ${1:-} == --write ]] && write=true
[[ ${1:-} == --readme ]] && readme_only=true
twinray=${TWINRAY:-$root/target/release/twinray}
[[ -x $twinray ]] || { echo "build first: cargo build --release" >&2; exit 2; }
export SPD=${SPD:-$root/../shared/scenes/spd}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

differ=0

# The README's examples, as a reader runs them.
mkdir "$tmp/readme"
ln -s "$root/scenes" "$tmp/readme/scenes"
while IFS= read -r cmd; do
  read -r -a words <<< "$cmd"
  words[0]=$twinray
  start=$SECONDS
  if ! (cd "$tmp/readme" && "${words[@]}") >/dev/null 2>"$tmp/err"; then
    printf 'README example FAILED: %s\n  %s\n' "$cmd" "$(tail -1 "$tmp/err")"
    differ=1
  elif grep -q 'warning' "$tmp/err"; then
    printf 'README example WARNS: %s\n  %s\n' "$cmd" "$(grep -m1 warning "$tmp/err")"
    differ=1
  else
    printf 'README example ok (%d s): %s\n' "$((SECONDS - start))" "$cmd"
  fi
done < <(awk '/^```sh/ { on = 1; next } /^```/ { on = 0 } on && /^twinray / && !/^twinray preview/ && !/-o docs\/images\//' README.md)
$readme_only && exit "$differ"

# The inputs that scripts make, where the documents say they are.
python3 docs/images/leaves.py /tmp/leaves >/dev/null
python3 docs/images/pbr_grid.py docs/images/pbr-grid.gltf >/dev/null

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
