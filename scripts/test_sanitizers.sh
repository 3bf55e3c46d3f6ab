#!/usr/bin/env bash
# The sanitizer suite: every gtest binary and every rostest again, built with
# AddressSanitizer + UndefinedBehaviorSanitizer (-DBDIS_SANITIZE=ON) in a
# second workspace, $WS_DIR/asan. scripts/test.sh calls it after the normal
# tests:
#   scripts/test_sanitizers.sh RESULTS_DIR     # results in RESULTS_DIR/asan/
# Any report fails. Processes stop at the first one (halt_on_error), and every
# report also goes to a file under RESULTS_DIR/asan/reports/<test>/, which
# becomes a failed test case "no_sanitizer_report" of that test binary or
# .test file; so a report from a process whose exit status nobody checks (a
# nodelet manager, or a tool a test runs) still fails the suite.
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

[ $# -eq 1 ] || { echo "usage: $0 RESULTS_DIR" >&2; exit 2; }
RESULTS_DIR="$1/asan"
MAIN_WS_DIR="$WS_DIR"
# Inside the main workspace: ignored by git and never linked as package source.
WS_DIR="$MAIN_WS_DIR/asan"

# test.sh has sourced the main workspace. Drop its entries from the environment,
# or the sanitizer workspace would chain onto it (two bdis_stereo packages on
# ROS_PACKAGE_PATH, the other one's libraries on LD_LIBRARY_PATH).
drop_from_path_lists "$MAIN_WS_DIR" CMAKE_PREFIX_PATH LD_LIBRARY_PATH PKG_CONFIG_PATH PYTHONPATH ROS_PACKAGE_PATH PATH

# Only what the tests need: no benchmark, no rendered sample.
build_package -DBDIS_SANITIZE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  tests bdis_stereo_nodelet bdis_stereo_node
source_workspace

rm -rf "$RESULTS_DIR"
mkdir -p "$RESULTS_DIR/bdis_stereo"
REPORTS_DIR="$RESULTS_DIR/reports"

# Reports of test NAME go to REPORTS_DIR/NAME/report.<pid>. Leaks are checked
# at every exit; test/sanitizers/asan.supp lists (and explains) the errors of
# libraries we do not own that are left out.
sanitizer_environment() {
  local log="$REPORTS_DIR/$1/report"
  mkdir -p "$REPORTS_DIR/$1"
  export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1:check_initialization_order=1:log_path=$log"
  ASAN_OPTIONS+=":suppressions=$REPO_DIR/test/sanitizers/asan.supp"
  export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:log_path=$log"

}

# One JUnit case per test binary or .test file: fails when a sanitizer wrote a
# report, or when the test died without writing its results.
record_reports() {
  local name="$1" results_written="$2" reports
  reports=("$REPORTS_DIR/$name"/report.*)
  [ -e "${reports[0]}" ] || reports=()
  local out="$RESULTS_DIR/bdis_stereo/sanitizer-$name.xml"
  if [ ${#reports[@]} -gt 0 ]; then
    log "$name: ${#reports[@]} sanitizer report(s):"
    cat "${reports[@]}" >&2
    local details=() report
    for report in "${reports[@]}"; do details+=(--details "$report"); done
    junit_case "$out" "asan.$name" no_sanitizer_report \
      --failure "${#reports[@]} sanitizer report(s) in $REPORTS_DIR/$name" "${details[@]}"
    return 1
  elif [ "$results_written" != yes ]; then
    junit_case "$out" "asan.$name" no_sanitizer_report \
      --failure "$name wrote no results (crashed?) and no sanitizer report"
    return 1
  fi
  junit_case "$out" "asan.$name" no_sanitizer_report
}

# The gtest binaries, as many at a time as there are cores (test_synth alone
# takes about 3 minutes under ASan); each one's output in RESULTS_DIR/NAME.log.
run_gtest() {
  local test_bin="$1" name
  name="$(basename "$test_bin")"
  sanitizer_environment "$name"
  local rc=0
  "$test_bin" --gtest_output="xml:$RESULTS_DIR/bdis_stereo/gtest-$name.xml" \
    >"$RESULTS_DIR/$name.log" 2>&1 || rc=$?
  echo "$rc" >"$RESULTS_DIR/$name.exit"
}
status=0
test_bins=()
for test_bin in "$WS_DIR"/devel/lib/bdis_stereo/test_*; do
  [ -x "$test_bin" ] || continue
  test_bins+=("$test_bin")
  while [ "$(jobs -rp | wc -l)" -ge "$(nproc)" ]; do wait -n || true; done
  log "running $(basename "$test_bin") (ASan + UBSan)"
  run_gtest "$test_bin" &
done
wait
for test_bin in "${test_bins[@]}"; do
  name="$(basename "$test_bin")"
  xml="$RESULTS_DIR/bdis_stereo/gtest-$name.xml"
  grep -E '^\[(==========|  PASSED  |  FAILED  )\]' "$RESULTS_DIR/$name.log" | sed "s/^/$name: /" || true
  if [ "$(cat "$RESULTS_DIR/$name.exit")" != 0 ]; then
    status=1
    tail -n 60 "$RESULTS_DIR/$name.log"
    log "$name failed under ASan (full output: $RESULTS_DIR/$name.log)"
  fi
  record_reports "$name" "$([ -s "$xml" ] && echo yes)" || status=1
done

# rostests: the nodelet managers (the nodelet package's binary, not built with
# ASan) load the instrumented nodelet, so they get the ASan runtime preloaded
# through the launch files' launch-prefix="$(optenv BDIS_LAUNCH_PREFIX)".
# Nothing else is preloaded: Python nodes and ROS tools run as usual.
ros_on_loopback
cxx="$(sed -n 's/^CMAKE_CXX_COMPILER:[A-Z]*=//p' "$WS_DIR/build/CMakeCache.txt")"
asan_runtime="$(readlink -f "$("${cxx:-c++}" -print-file-name=libasan.so)")"
if [ ! -f "$asan_runtime" ]; then
  log "ASan runtime not found (libasan.so of ${cxx:-c++}): cannot run the rostests"
  junit_case "$RESULTS_DIR/bdis_stereo/sanitizer-rostests.xml" asan.rostests runtime_found \
    --failure "libasan.so of ${cxx:-c++} not found"
  exit 1
fi
export BDIS_LAUNCH_PREFIX="env LD_PRELOAD=$asan_runtime"
# LeakSanitizer's exit-time tracer now and then crashes in a process with many
# threads (a nodelet manager): "Tracer caught signal 11 ... LeakSanitizer has
# encountered a fatal error" (google/sanitizers#1353). Such a report holds no
# finding (the leak check never ran), so a rostest whose only reports are that
# runs once more; a real report, or the crash twice, still fails.
only_tracer_crashes() {
  local reports=("$REPORTS_DIR/$1"/report.*) report
  [ -e "${reports[0]}" ] || return 1
  for report in "${reports[@]}"; do
    grep -q "LeakSanitizer has encountered a fatal error" "$report" || return 1
    ! grep -qE "ERROR: (Address|Leak)Sanitizer|runtime error|SUMMARY:" "$report" || return 1
  done
}
for test_file in "$REPO_DIR"/test/ros/*.test; do
  [ -e "$test_file" ] || continue
  name="$(basename "$test_file" .test)"
  sanitizer_environment "rostest-$name"
  rc=0
  run_rostest "$test_file" "$RESULTS_DIR" "ASan + UBSan" || rc=1
  if only_tracer_crashes "rostest-$name"; then
    log "rostest-$name: LeakSanitizer's tracer crashed (no finding); running it once more"
    mkdir -p "$REPORTS_DIR/rostest-$name.tracer-crash"
    mv "$REPORTS_DIR/rostest-$name"/report.* "$REPORTS_DIR/rostest-$name.tracer-crash/"
    rc=0
    run_rostest "$test_file" "$RESULTS_DIR" "ASan + UBSan, again" || rc=1
  fi
  [ "$rc" = 0 ] || status=1
  # rostest writes its own result file (a failed case when the test node crashed).
  record_reports "rostest-$name" yes || status=1
done
exit $status
