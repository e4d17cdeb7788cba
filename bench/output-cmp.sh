#!/usr/bin/env bash
# Do two builds write the same files? Renders one set of outputs with each
# binary, every layout and file kind a user may ask for (a mono image in PNG,
# linear PNG, JPEG, with an exposure, anti-aliased; pairs separate, side by
# side, crossed, top-bottom, squeezed, anaglyph, interlaced, MPO, PFM, with a
# floating window, a tile; five views; quilts of the twin method and of the
# fast method, linear JPEG, tone-mapped), and compares every file with `cmp`.
# For a change that must not move a byte of any output.
#
# usage (from the project root):  bench/output-cmp.sh OLD_BIN NEW_BIN
# Scenes: scenes/example.nff and, for the quilts, $SPD/tetra.nff
# (default ../shared/scenes/spd; scenes/deep.nff when that is missing).
set -uo pipefail
[[ $# -eq 2 ]] || { sed -n 2,12p "$0" >&2; exit 2; }
old=$1 new=$2
S=scenes/example.nff
T=${SPD:-../shared/scenes/spd}/tetra.nff
[[ -f $T ]] || T=scenes/deep.nff
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/a" "$tmp/b"
failed=0
run() { # NAME ARGS...: both binaries write NAME
  local n=$1; shift
  for which in a b; do
    local bin=$old; [[ $which == b ]] && bin=$new
    "$bin" render "$@" -o "$tmp/$which/$n" -q 2> "$tmp/err" || {
      echo "FAILED ($which) $n: $(cat "$tmp/err")"; failed=1; }
  done
}
run mono.png $S --size 160x120 --samples 1
run mono-lin.png $S --size 160x120 --samples 1 --linear
run mono.jpg $S --size 160x120 --samples 1
run mono-exp.png $S --size 160x120 --samples 1 --exposure 1
run mono-aa.png $S --size 160x120
run pair.png $S --size 160x120 --samples 1 --stereo
run pairsbs.png $S --size 160x120 --samples 1 --stereo --layout sbs
run pairana.png $S --size 160x120 --samples 1 --stereo --layout anaglyph
run pairfw.png $S --size 160x120 --samples 1 --stereo --floating-window
run paircross.png $S --size 160x120 --samples 1 --stereo --layout cross
run pairtb.jpg $S --size 160x120 --samples 1 --stereo --layout tb
run pairsq.png $S --size 160x120 --samples 1 --stereo --layout sbs --squeeze
run pairil.png $S --size 161x121 --samples 1 --stereo --layout interlace --interlace checker
run pairmpo.mpo $S --size 160x120 --samples 1 --stereo --layout mpo
run tilesbs.png $S --size 160x120 --samples 1 --stereo --layout sbs --tiles 3 --tile 2
run pair.pfm $S --size 160x120 --samples 1 --stereo
run tile.png $S --size 160x120 --samples 1 --stereo --tiles 3 --tile 1
run five.jpg $S --size 160x120 --samples 1 --views 5
run quilt.png $T --size 105x140 --samples 1 --views 48 --layout quilt --quilt portrait
run quilt-fast.png $T --size 105x140 --samples 1 --views 48 --layout quilt --quilt portrait --fast
run quilt.jpg $T --size 105x140 --samples 1 --views 12 --layout quilt --quilt 4x3 --linear
run quilt-tone.png $T --size 105x140 --samples 1 --views 12 --layout quilt --quilt 4x3 --tonemap agx
(cd "$tmp/a" && find . -type f | sort) > "$tmp/la"
(cd "$tmp/b" && find . -type f | sort) > "$tmp/lb"
if ! diff "$tmp/la" "$tmp/lb"; then echo "the file lists differ"; exit 1; fi
while read -r f; do
  cmp -s "$tmp/a/$f" "$tmp/b/$f" || { echo "differs: $f"; failed=1; }
done < "$tmp/la"
[[ $failed == 0 ]] && echo "$(wc -l < "$tmp/la") files, all identical"
exit $failed
