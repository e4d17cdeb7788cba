#!/usr/bin/env bash
# Animation, video and tiles, measured on one machine (docs/benchmarks.md#animation):
#  1. a 240-frame stereo orbit of SPD teapot, 640x360 per eye, side-by-side
#     H.264 MP4: peak RSS of the whole shot against one frame's (a still of
#     the same flags, and a 1-frame video);
#  2. tiles of one 4096x4096 still merged against the single render (cmp);
#  3. (with twinray-ray installed) 48 frames on a local 2-CPU Ray cluster
#     (two tasks of one thread) against one twinray process of two threads.
# Usage: bench/animation.sh [TEAPOT.nff]   (default ../shared/scenes/spd/teapot.nff)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
scene=${1:-../shared/scenes/spd/teapot.nff}
bin=target/release/twinray
cargo build --release --bin twinray >/dev/null 2>&1
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

rss() { # peak RSS in MiB of a command
    /usr/bin/time -f '%M' -o "$out/rss" "$@" >/dev/null 2>&1
    echo "scale=1; $(cat "$out/rss") / 1024" | bc
}
secs() { # wall seconds of a command
    local t0=$(date +%s.%N); "$@" >/dev/null 2>&1; echo "$(date +%s.%N) - $t0" | bc
}

flags=(--stereo --layout sbs --size 640x360 -q)
echo "== 1. memory over a 240-frame SBS MP4 ($scene, 640x360 per eye)"
still=$(rss "$bin" render "$scene" -o "$out/still.png" "${flags[@]}")
one=$(rss "$bin" render "$scene" -o "$out/one.mp4" --frames 0..0 --orbit 360 "${flags[@]}")
t0=$(date +%s.%N)
shot=$(rss "$bin" render "$scene" -o "$out/shot.mp4" --frames 0..239 --orbit 360 "${flags[@]}")
t1=$(date +%s.%N)
frames=$(ffprobe -v error -count_frames -select_streams v:0 -show_entries stream=nb_read_frames -of csv=p=0 "$out/shot.mp4")
echo "peak RSS: still ${still} MiB, 1-frame video ${one} MiB, 240-frame video ${shot} MiB ($frames frames, $(echo "$t1 - $t0" | bc) s)"
echo "ratio 240 frames / still: $(echo "scale=3; $shot / $still" | bc); / 1-frame video: $(echo "scale=3; $shot / $one" | bc)"

echo "== 2. tiles of a 4096x4096 still"
big=(--size 4096x4096 -q)
tw=$(secs "$bin" render "$scene" -o "$out/whole.png" "${big[@]}")
tt=$(secs "$bin" render "$scene" -o "$out/tiled.png" --tiles 8 "${big[@]}")
tm=$(secs "$bin" merge "$out"/tiled_tile*of8.png -o "$out/merged.png")
if cmp -s "$out/whole.png" "$out/merged.png"; then same=identical; else same=DIFFERENT; fi
echo "whole ${tw} s; 8 tiles one after the other ${tt} s; merge ${tm} s; merged vs whole: $same (cmp of the PNG files)"

if command -v twinray-ray >/dev/null; then
    echo "== 3. 48 frames: 2-task local Ray cluster vs one twinray process"
    fr=(--frames 0..47 --orbit 90 --stereo --layout sbs --size 640x360)
    single=$(secs "$bin" render "$scene" -o "$out/single_####.png" "${fr[@]}" --threads 2 -q)
    onray=$(secs twinray-ray render "$scene" -o "$out/ray_####.png" "${fr[@]}" --twinray "$bin" --num-cpus 2 --cpus-per-task 1 --chunk 6 -q)
    diffs=0
    for f in "$out"/single_*.png; do cmp -s "$f" "${f/single_/ray_}" || diffs=$((diffs + 1)); done
    echo "one process (2 threads) ${single} s; Ray, 2 tasks x 1 thread, chunks of 6: ${onray} s (cluster start included)"
    echo "throughput Ray / one process: $(echo "scale=3; $single / $onray" | bc); frames differing: $diffs"
fi
