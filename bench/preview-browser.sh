#!/usr/bin/env bash
# The live preview's latency as a browser shows it (issue 18): for each SPD
# scene, `twinray preview SCENE --size 480x270` (release build) in headless
# Chromium; 20 changes of interaxial through the page's slider, each when the
# previous one's first frame is painted; the page times each change from
# sending it to the animation frame after its first image loaded.
#
#   bench/preview-browser.sh [WxH]     (needs chromium; SPD=DIR as bench/preview.sh)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
size=${1:-480x270}
spd=${SPD:-../shared/scenes/spd}
cargo build --release -q --bin twinray
cargo test -q -p twinray-preview --test all --no-run 2>/dev/null
for scene in "$spd"/*.nff; do
    out=$(mktemp)
    target/release/twinray preview "$scene" --size "$size" > "$out" 2>&1 &
    server=$!
    for _ in $(seq 100); do grep -q http "$out" && break; sleep 0.1; done
    url=$(grep -o 'http://[^ ]*' "$out")
    line=$(TWINRAY_PREVIEW_URL=$url cargo test -q -p twinray-preview --test all browser::on_screen_latency \
        -- --ignored --nocapture 2>&1 | grep '^on-screen' || echo "on-screen: failed")
    printf '%s\t%s\n' "$(basename "$scene" .nff)" "$line"
    kill "$server"; wait "$server" 2>/dev/null || true
    rm -f "$out"
done
