#!/usr/bin/env bash
# The demo command: installs what is missing, builds the package in _ws/ (which
# renders the embedded sample), then runs scripts/bdis_demo: roscore, the
# nodelet through demo.launch, the sample replayed as a bag, a report, and
# pictures + a point cloud in out/demo/ (or --out DIR).
#   ./scripts/demo.sh                      # headless, ~1 min once installed and built
#   ./scripts/demo.sh --rviz               # with rviz (needs a display)
#   ./scripts/demo.sh --bag my.bag --left-image /cam/left/image_rect ...   (--help: all options)
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

prepare_ros_run   # the demo starts its own master, on loopback
exec "$PYTHON_EXE" "$WS_DIR/devel/lib/bdis_stereo/bdis_demo" --out "$REPO_DIR/out/demo" "$@"
