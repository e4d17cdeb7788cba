#!/usr/bin/env bash
# Long runs of the fuzzers:
#
# * the NFF mutation fuzzer (crates/twinray/tests/all/fuzz.rs): every mutant of
#   the shipped scenes must be refused with file and line, or load and
#   render (mono, and a stereo pair whose twin and independent images agree
#   bit for bit) without a panic and with finite pixels;
# * the loaders' fuzzer (crates/twinray/tests/all/fuzz_loaders.rs): mutants of
#   real OBJ, MTL, glTF, GLB, buffer and PNG files must load and render with
#   finite pixels, or be refused in one line naming the file; the glTF's
#   buffer and image URIs replaced by hostile ones (outside the folder,
#   %-escaped, absolute, /dev/zero, a FIFO, a link out) must end, and read
#   nothing outside the scene's folder.
#
#   scripts/fuzz.sh [MUTANTS] [SEED]     (default 100000 mutants, seed 1)
#
# MUTANTS is the NFF fuzzer's count; each of the loaders' seven targets gets
# a twentieth of it. The test suite runs 2000 NFF mutants with seed 11 and
# 150 a target with seed 1.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
mutants="${1:-100000}"
seed="${2:-1}"
TWINRAY_FUZZ_MUTANTS="$mutants" TWINRAY_FUZZ_SEED="$seed" \
    cargo test --release -p twinray --test all fuzz:: -- --nocapture 2>&1 | grep -E "fuzz:|mutant|test result"
TWINRAY_FUZZ_ITERS="$((mutants / 20))" TWINRAY_FUZZ_SEED="$seed" \
    cargo test --release -p twinray --test all fuzz_loaders:: -- --nocapture 2>&1 \
    | grep -E "mutants|mutant |panicked|test result"
