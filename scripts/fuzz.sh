#!/usr/bin/env bash
# A long run of the NFF mutation fuzzer (crates/twinray/tests/fuzz.rs): every
# mutant of the shipped scenes must be refused with file and line, or load and
# render (mono, and a stereo pair whose twin and independent images agree bit
# for bit) without a panic and with finite pixels.
#
#   scripts/fuzz.sh [MUTANTS] [SEED]     (default 100000 mutants, seed 1)
#
# The test suite runs 2000 mutants with seed 11. About 1 s per 2000 mutants
# on one core of the project's machine.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
TWINRAY_FUZZ_MUTANTS="${1:-100000}" TWINRAY_FUZZ_SEED="${2:-1}" \
    cargo test --release -p twinray --test all fuzz:: -- --nocapture 2>&1 | grep -E "fuzz:|mutant|test result"
