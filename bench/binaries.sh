# Sourced by the bench scripts that run several builds side by side on the
# same scenes (`... BIN[,FLAG...] ... -- SCENE...`; a binary may carry flags
# after commas, e.g. `target/release/twinray,--fast`).

# split_binaries ARGS...: the arguments before `--` into `bins`, those after
# into `scenes`; fails when either is empty.
split_binaries() {
  bins=() scenes=()
  while [[ $# -gt 0 && $1 != -- ]]; do bins+=("$1"); shift; done
  [[ $# -gt 0 ]] && shift
  scenes=("$@")
  [[ ${#bins[@]} -ge 1 && ${#scenes[@]} -ge 1 ]]
}

# measure BIN render ARGS...: one render, one thread, --samples 1, its
# statistics and timing kept in $tmp; prints "render_s cpu_s" (--stats'
# render time, and the user + system CPU seconds of the whole command).
measure() {
  /usr/bin/time -f '%U %S' -o "$tmp/time" "$@" --samples 1 --threads 1 -q \
    --stats "$tmp/stats.json" 2>/dev/null
  read -r u s < "$tmp/time"
  python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['time']['render_s'], $u + $s)" \
    "$tmp/stats.json"
}
