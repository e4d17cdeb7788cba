#!/usr/bin/env bash
# What alpha cut-outs cost, and that scenes without them pay nothing
# (docs/benchmarks.md#alpha-cut-outs). CPU seconds (user + sys) of one
# thread, medians of ROUNDS interleaved runs:
#  1. scenes without alpha (SPD balls, teapot; the textured torus OBJ): the
#     binary OLD (before alpha) against NEW;
#  2. the leaves of docs/images/leaves.py with their map_d cut-outs against
#     the same file without map_d (opaque quads), both by NEW.
# Usage: bench/alpha-cost.sh OLD_BINARY NEW_BINARY [ROUNDS]   (default 5)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
old=$1 new=$2 rounds=${3:-5}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
python3 docs/images/leaves.py "$out/leaves"
sed 's/^map_d .*//' "$out/leaves/leaves.mtl" > "$out/leaves/opaque.mtl"
sed 's/leaves.mtl/opaque.mtl/' "$out/leaves/leaves.obj" > "$out/leaves/opaque.obj"

cpu() { # CPU seconds of a command
    /usr/bin/time -f '%U %S' -o "$out/t" "$@" >/dev/null 2>&1
    awk '{print $1 + $2}' "$out/t"
}
median() { sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2] + a[NR/2+1]) / 2}'; }
compare() { # label, binary A, binary B, then the render arguments for A and B, split by --
    local label=$1 a=$2 b=$3; shift 3
    local args_a=() args_b=()
    while [ "$1" != "--" ]; do args_a+=("$1"); shift; done; shift
    args_b=("$@")
    : > "$out/a"; : > "$out/b"
    for _ in $(seq "$rounds"); do
        cpu "$a" render "${args_a[@]}" -o "$out/a.png" -q --threads 1 >> "$out/a"
        cpu "$b" render "${args_b[@]}" -o "$out/b.png" -q --threads 1 >> "$out/b"
    done
    local ma mb
    ma=$(median < "$out/a"); mb=$(median < "$out/b")
    echo "$label: $ma s vs $mb s, ratio $(echo "scale=3; $mb / $ma" | bc)"
}

echo "== 1. without alpha: NEW / OLD"
for s in ../shared/scenes/spd/balls.nff ../shared/scenes/spd/teapot.nff \
         crates/twinray/tests/data/models/pybullet/torus/torus_textured.obj; do
    [ -f "$s" ] || { echo "$s: missing, skipped"; continue; }
    compare "$(basename "$s") 512x512" "$old" "$new" "$s" --size 512x512 -- "$s" --size 512x512
    compare "$(basename "$s") 512x512 stereo" "$old" "$new" "$s" --size 512x512 --stereo -- "$s" --size 512x512 --stereo
done
echo "== 2. the leaves: cut-outs / opaque quads (NEW)"
leaf=(--size 480x360 --ground)
compare "leaves 480x360" "$new" "$new" "$out/leaves/opaque.obj" "${leaf[@]}" -- "$out/leaves/leaves.obj" "${leaf[@]}"
compare "leaves 480x360 stereo" "$new" "$new" "$out/leaves/opaque.obj" "${leaf[@]}" --stereo -- "$out/leaves/leaves.obj" "${leaf[@]}" --stereo
