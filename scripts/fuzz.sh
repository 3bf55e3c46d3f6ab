#!/usr/bin/env bash
# libFuzzer over the core (fuzz/fuzz_matcher.cpp): builds it with clang (plain
# CMake, fuzz/CMakeLists.txt, in $WS_DIR/fuzz), replays the seed corpus
# (fuzz/corpus) and every kept crash input (fuzz/regressions), then fuzzes for
# BDIS_FUZZ_SECONDS (default 60).
#   scripts/fuzz.sh [RESULTS_DIR]      # test.sh: JUnit cases in RESULTS_DIR/fuzz/
#   BDIS_FUZZ_SECONDS=3600 scripts/fuzz.sh
# New interesting inputs go to $WS_DIR/fuzz/corpus (kept between runs, not
# committed); a crashing input is written to $WS_DIR/fuzz/artifacts/: copy it
# into fuzz/regressions/ with the fix so it is replayed from then on.
# Without clang the fuzzer is skipped, except under CI=true on Debian, where
# scripts/common.sh installs clang (DEBIAN_PACKAGES).
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

RESULTS_DIR="${1:+$1/fuzz}"
FUZZ_SECONDS="${BDIS_FUZZ_SECONDS:-60}"
BUILD_DIR="$WS_DIR/fuzz"
ARTIFACTS_DIR="$BUILD_DIR/artifacts"
FUZZER="$BUILD_DIR/fuzz_matcher"

# result NAME [junit_case.py options]: one JUnit case when RESULTS_DIR is given.
result() {
  local name="$1"
  shift
  [ -n "$RESULTS_DIR" ] || return 0
  junit_case "$RESULTS_DIR/fuzz-$name.xml" fuzz.fuzz_matcher "$name" "$@"
}

clangxx=""
for candidate in clang++-14 clang++; do
  if command -v "$candidate" >/dev/null 2>&1; then clangxx="$(command -v "$candidate")"; break; fi
done
if [ -z "$clangxx" ]; then
  if [ "${CI:-}" = "true" ] && [ ! -f /opt/ros/noetic/setup.bash ]; then
    log "clang++ not found: the fuzzer cannot run (scripts/common.sh installs it on Debian)"
    result build --failure "clang++ not found"
    exit 1
  fi
  log "clang++ not found: skipping the fuzzer"
  result build --skipped "clang++ not found"
  exit 0
fi

[ -z "$RESULTS_DIR" ] || { rm -rf "$RESULTS_DIR"; mkdir -p "$RESULTS_DIR"; }
mkdir -p "$BUILD_DIR/corpus" "$ARTIFACTS_DIR"
log "building the fuzzer with $clangxx in $BUILD_DIR"
if ! (cmake -S "$REPO_DIR/fuzz" -B "$BUILD_DIR" -DCMAKE_CXX_COMPILER="$clangxx" \
        -DCMAKE_BUILD_TYPE=None && cmake --build "$BUILD_DIR" -j"$(nproc)") \
     >"$BUILD_DIR/build.log" 2>&1; then
  tail -n 40 "$BUILD_DIR/build.log"
  log "fuzzer build failed (full log: $BUILD_DIR/build.log)"
  result build --failure "the fuzzer does not build" --details "$BUILD_DIR/build.log"
  exit 1
fi

# A report must stop the run with a non-zero status; leaks are checked too.
export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
FUZZ_FLAGS=(-timeout=30 -rss_limit_mb=2048 -artifact_prefix="$ARTIFACTS_DIR/")

status=0
# Replay: every input of the seed corpus and of the regressions once.
replay_log="$BUILD_DIR/replay.log"
log "fuzzer: replaying fuzz/corpus and fuzz/regressions"
if "$FUZZER" "${FUZZ_FLAGS[@]}" -runs=0 "$REPO_DIR/fuzz/corpus" "$REPO_DIR/fuzz/regressions" \
    >"$replay_log" 2>&1; then
  result replay_corpus_and_regressions --output "$(grep -E '^#[0-9]+ +(INITED|DONE)' "$replay_log" | tail -n 2)"
else
  status=1
  tail -n 60 "$replay_log"
  log "fuzzer: a kept input fails (full log: $replay_log)"
  result replay_corpus_and_regressions --failure "a corpus or regression input fails" \
    --details "$replay_log"
fi

# Fuzzing: new inputs to the (uncommitted) working corpus, the committed ones as seeds.
if [ "$FUZZ_SECONDS" -gt 0 ]; then
  fuzz_log="$BUILD_DIR/fuzz.log"
  log "fuzzer: fuzzing for ${FUZZ_SECONDS} s"
  if "$FUZZER" "${FUZZ_FLAGS[@]}" -max_total_time="$FUZZ_SECONDS" -print_final_stats=1 \
      "$BUILD_DIR/corpus" "$REPO_DIR/fuzz/corpus" "$REPO_DIR/fuzz/regressions" \
      >"$fuzz_log" 2>&1; then
    stats="$(grep -E '^stat::(number_of_executed_units|average_exec_per_sec|new_units_added)' "$fuzz_log" || true)"
    log "fuzzer: no finding in ${FUZZ_SECONDS} s; $(echo "$stats" | tr '\n' ' ')"
    result "fuzz_${FUZZ_SECONDS}s" --output "$stats"
  else
    status=1
    tail -n 80 "$fuzz_log"
    log "fuzzer: finding (full log: $fuzz_log); the input is in $ARTIFACTS_DIR: fix the bug" \
        "and add the input to fuzz/regressions/"
    result "fuzz_${FUZZ_SECONDS}s" --failure "the fuzzer found a crash or a broken contract" \
      --details "$fuzz_log"
  fi
fi
exit $status
