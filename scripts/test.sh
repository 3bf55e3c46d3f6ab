#!/usr/bin/env bash
# The one test command: installs what is missing, builds, runs every test and
# prints "N passed, N failed". Exits non-zero on any failure.
# Data: ../shared/data or $BDIS_DATA_DIR; under CI=true a test that needs it and
# cannot find it fails instead of skipping.
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

install_dependencies
build_package
build_package tests
source_workspace

RESULTS_DIR="$WS_DIR/build/test_results"
rm -rf "$RESULTS_DIR"
mkdir -p "$RESULTS_DIR/bdis_stereo"

status=0
for test_bin in "$WS_DIR"/devel/lib/bdis_stereo/test_*; do
  [ -x "$test_bin" ] || continue
  name="$(basename "$test_bin")"
  log "running $name"
  "$test_bin" --gtest_output="xml:$RESULTS_DIR/bdis_stereo/gtest-$name.xml" || status=1
done

# Summary over every result file.
"$PYTHON_EXE" "$REPO_DIR/scripts/summarize_results.py" "$RESULTS_DIR" || status=1
exit $status
