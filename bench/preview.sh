#!/usr/bin/env bash
# The live preview's latency on the SPD scenes (issue 18): the first frame of
# a page, a change of interaxial -> the new rig's first (1/8) frame (median
# and 90th percentile over 20 changes made one after another, each cancelling
# the render in flight), the first full-size frame, and the server's memory
# before and after 10 quick reconnects. Times are taken at a WebSocket client
# on the loopback interface (the browser's decoding and painting excluded).
#
#   bench/preview.sh [WxH]     (default 480x270 per view, anaglyph)
#
# SPD=DIR sets where the .nff files are (default ../shared/scenes/spd).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
size=${1:-480x270}
spd=${SPD:-../shared/scenes/spd}
cargo build --release -q -p twinray-preview --example preview_latency
target/release/examples/preview_latency "$size" "$spd"/*.nff | column -t
