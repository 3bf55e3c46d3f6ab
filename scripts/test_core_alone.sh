#!/usr/bin/env bash
# The ROS-free core as its own CMake project, as a user without ROS builds it:
# `cmake -S core` in an environment with nothing of ROS or the workspace in
# it (no setup.bash sourced, no ROS_* or catkin variables), the library, the
# tools and the unit tests built, and ctest run over them.
#   scripts/test_core_alone.sh RESULTS_DIR   # test.sh: JUnit cases in RESULTS_DIR/core_alone/
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

[ $# -eq 1 ] || { echo "usage: $0 RESULTS_DIR" >&2; exit 2; }
RESULTS_DIR="$1/core_alone"
BUILD_DIR="$WS_DIR/core_alone"
rm -rf "$RESULTS_DIR"
mkdir -p "$RESULTS_DIR" "$BUILD_DIR"

# Only what a shell without ROS has; the shared data stays reachable.
clean_env=(env -i "HOME=$HOME" "PATH=/usr/local/bin:/usr/bin:/bin" "BDIS_DATA_DIR=${BDIS_DATA_DIR:-}"
           "CI=${CI:-}" "LANG=C.UTF-8")

log "building core/ with plain CMake, no ROS in the environment ($BUILD_DIR)"
if ! "${clean_env[@]}" bash -c 'cmake -S "$1" -B "$2" -DCMAKE_BUILD_TYPE=Release -DBDIS_BUILD_BENCHMARKS=OFF &&
                                cmake --build "$2" -j"$(nproc)"' _ "$REPO_DIR/core" "$BUILD_DIR" \
     >"$BUILD_DIR/build.log" 2>&1; then
  tail -n 40 "$BUILD_DIR/build.log"
  log "core/ does not build on its own (full log: $BUILD_DIR/build.log)"
  junit_case "$RESULTS_DIR/build.xml" core_alone.cmake build --failure "core/ does not build with plain CMake" \
    --details "$BUILD_DIR/build.log"
  exit 1
fi
junit_case "$RESULTS_DIR/build.xml" core_alone.cmake build --output "$(tail -n 5 "$BUILD_DIR/build.log")"

log "ctest over the core's unit tests"
if ! "${clean_env[@]}" ctest --test-dir "$BUILD_DIR" --output-on-failure \
       --output-junit "$RESULTS_DIR/ctest.xml" >"$BUILD_DIR/ctest.log" 2>&1; then
  tail -n 60 "$BUILD_DIR/ctest.log"
  log "the core's tests fail when built alone (full log: $BUILD_DIR/ctest.log)"
  [ -s "$RESULTS_DIR/ctest.xml" ] || junit_case "$RESULTS_DIR/ctest_ran.xml" core_alone.ctest ran \
    --failure "ctest wrote no results" --details "$BUILD_DIR/ctest.log"
  exit 1
fi
