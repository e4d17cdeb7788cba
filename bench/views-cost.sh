#!/usr/bin/env bash
# N views against N mono renders of the same binary with the same flags:
# CPU time at --threads 1 and wall time on all cores, exact and --fast, with
# each --fast view's PSNR and share of pixels off by more than 16/255 against
# the exact view. Prints the table, writes CSV and the plot. See
# bench/views_cost.py for the details and the settings.
#
# usage (from the project root, after cargo build --release --bin twinray):
#   bench/views-cost.sh [SCENE.nff ...]      (default: SPD balls mount tetra tree)
#   e.g. VIEWS=2 SIZE=1024x1024 INTERAXIAL=0.1 CSV=/tmp/pair.csv PLOT= \
#          bench/views-cost.sh ../shared/scenes/spd/*.nff
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
exec python3 bench/views_cost.py "$@"
