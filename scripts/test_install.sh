#!/usr/bin/env bash
# The install space, as a user gets it: `catkin_make install` of the test
# workspace's build into $WS_DIR/install, then, in a clean environment with
# only install/setup.bash sourced (no devel space, nothing of the checkout on
# any path), what a user runs:
#   help        each tool's --help (bdis_match, bdis_eval, bdis_synth, bdis_demo,
#               bdis_make_bag), found by rosrun in the install space
#   tools       bdis_synth renders a tiny pair, bdis_match and bdis_eval run on it
#   make_bag    bdis_make_bag turns it into a bag
#   launch      roslaunch --files / --nodes of bdis_stereo.launch and demo.launch:
#               every file from the install space
#   sample      the embedded sample is installed where bdis_demo looks
#   downstream  a CMake project finds the package (find_package(bdis_stereo)),
#               compiles against the installed headers and links the core
#   nodelet     roscore on a free loopback port, bdis_stereo.launch, the bag
#               replayed: the nodelet subscribes, and a disparity comes out
# Every process it starts is stopped by its PID.
#   scripts/test_install.sh RESULTS_DIR      # test.sh: JUnit cases in RESULTS_DIR/install/
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

[ $# -eq 1 ] || { echo "usage: $0 RESULTS_DIR" >&2; exit 2; }
RESULTS_DIR="$1/install"
INSTALL_DIR="$WS_DIR/install"
WORK="$WS_DIR/install_test"
rm -rf "$RESULTS_DIR" "$INSTALL_DIR" "$WORK"
mkdir -p "$RESULTS_DIR" "$WORK"

# The devel space stays out of the install's parent workspaces: drop what
# test.sh sourced from the environment of the build.
drop_from_path_lists "$WS_DIR" CMAKE_PREFIX_PATH LD_LIBRARY_PATH PKG_CONFIG_PATH PYTHONPATH ROS_PACKAGE_PATH

result() {  # NAME [junit_case.py options]
  local name="$1"
  shift
  junit_case "$RESULTS_DIR/install-$name.xml" install.install_space "$name" "$@"
}

log "catkin_make install into $INSTALL_DIR"
if ! build_package install -DCMAKE_INSTALL_PREFIX="$INSTALL_DIR"; then
  result catkin_make_install --failure "catkin_make install failed" --details "$WS_DIR/build.log"
  exit 1
fi
result catkin_make_install

status=0
# check NAME SCRIPT: runs the bash SCRIPT in the install environment, its output in WORK/NAME.log.
# The JUnit case gets the output without control characters (ROS logs colour
# their lines), which XML cannot hold.
check() {
  local name="$1" script="$2" log_file="$WORK/$1.log"
  log "install space: $name"
  local rc=0
  (in_install bash -euo pipefail -c "$script") >"$log_file" 2>&1 || rc=$?
  tr -d '\000-\010\013\014\016-\037' <"$log_file" >"$log_file.txt"
  if [ "$rc" -eq 0 ]; then
    result "$name" --output "$(tail -c 4000 "$log_file.txt")"
  else
    status=1
    tail -n 30 "$log_file"
    log "install space: $name failed (full log: $log_file)"
    result "$name" --failure "$name failed in the install space" --details "$log_file.txt"
  fi
}

# in_install CMD...: CMD with only the install space sourced (setup.bash reads
# the arguments of the shell that sources it: none), INSTALL_DIR and
# WORK for the checks' scripts, ROS on loopback.
# It replaces the shell it runs in: call it in a subshell, ( ... ) or with &,
# so that a background one's $! is the PID of CMD itself.
in_install() {
  exec env -i HOME="$HOME" PATH=/usr/local/bin:/usr/bin:/bin LANG=C.UTF-8 ROS_HOME="$WORK/ros_home" \
    ROS_IP=127.0.0.1 ROS_MASTER_URI="${MASTER_URI:-http://127.0.0.1:11311}" \
    INSTALL_DIR="$INSTALL_DIR" WORK="$WORK" \
    bash -c 'command=("$@"); set --; source "$INSTALL_DIR/setup.bash" || exit 1; exec "${command[@]}"' \
    in_install "$@"
}

check help '
  test "$(rospack find bdis_stereo)" = "$INSTALL_DIR/share/bdis_stereo"
  for tool in bdis_match bdis_eval bdis_synth bdis_demo bdis_make_bag; do
    found="$(catkin_find --without-underlays --libexec bdis_stereo "$tool")"
    case "$found" in "$INSTALL_DIR"/*) ;; *) echo "$tool found at $found"; exit 1 ;; esac
    rosrun bdis_stereo "$tool" --help >"$WORK/help-$tool.txt"
    grep -q "usage" "$WORK/help-$tool.txt"
    echo "$tool --help: $(head -n 1 "$WORK/help-$tool.txt")"
  done'

check tools '
  rosrun bdis_stereo bdis_synth --out "$WORK/seq" --frames 2 --width 160 --height 128 --quiet
  rosrun bdis_stereo bdis_match "$WORK/seq/left/000000.png" "$WORK/seq/right/000000.png" "$WORK/d.png"
  test -s "$WORK/d.png"
  rosrun bdis_stereo bdis_eval "$WORK/seq" --methods bdis --frames 1 --json "$WORK/eval.json"
  grep -q "\"method\": \"bdis\"" "$WORK/eval.json"'

check make_bag '
  rosrun bdis_stereo bdis_make_bag "$WORK/seq" "$WORK/seq.bag" --rate 10 --loops 5
  rosbag info "$WORK/seq.bag" | tee "$WORK/bag_info.txt"
  test "$(grep -cE "/stereo/(left|right)/(image_rect|camera_info) +10 msgs" "$WORK/bag_info.txt")" -eq 4'

check launch '
  for launch in bdis_stereo.launch demo.launch; do
    files="$(roslaunch --files bdis_stereo "$launch")"
    echo "$launch: $files"
    echo "$files" | while read -r f; do
      case "$f" in "$INSTALL_DIR"/*) ;; *) echo "$f is not in the install space"; exit 1 ;; esac
    done
  done
  nodes="$(roslaunch --nodes bdis_stereo bdis_stereo.launch)"
  echo "bdis_stereo.launch nodes: $nodes"
  echo "$nodes" | grep -qx /stereo/bdis_stereo
  echo "$nodes" | grep -qx /stereo/bdis_stereo_manager'

check sample '
  sample="$(python3 "$INSTALL_DIR/lib/bdis_stereo/bdis_common.py" sample-dir)"
  test "$sample" = "$INSTALL_DIR/share/bdis_stereo/sample"
  test -f "$sample/camera.yaml"
  echo "$(ls "$sample/left" | wc -l) frames in $sample"
  test "$(ls "$sample/left" | wc -l)" -gt 0'

mkdir -p "$WORK/downstream"
cat >"$WORK/downstream/CMakeLists.txt" <<'EOF'
cmake_minimum_required(VERSION 3.10)
project(bdis_downstream CXX)
set(CMAKE_CXX_STANDARD 17)
find_package(bdis_stereo REQUIRED)
add_executable(downstream downstream.cpp)
target_include_directories(downstream PRIVATE ${bdis_stereo_INCLUDE_DIRS})
target_link_libraries(downstream ${bdis_stereo_LIBRARIES})
EOF
cat >"$WORK/downstream/downstream.cpp" <<'EOF'
// Uses the installed core: depth of one disparity.
#include <cstdio>
#include "bdis_stereo/geometry.hpp"
int main() {
  const bdis::StereoCamera camera = bdis::StereoCamera::symmetric(500, 500, 80, 64, 0.005);
  camera.validate();
  std::printf("depth at d = 10: %.4f\n", camera.depth(10.0f));
  return camera.depth(10.0f) == 0.25f ? 0 : 1;
}
EOF
check downstream '
  cmake -S "$WORK/downstream" -B "$WORK/downstream/build" -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$WORK/downstream/build" >/dev/null
  "$WORK/downstream/build/downstream"'

# The nodelet: a master of its own on a free loopback port, bdis_stereo.launch.
port="$(free_port)"
MASTER_URI="http://127.0.0.1:$port"
pids=()
stop_started() {  # SIGINT (roslaunch and roscore then stop their nodes), SIGKILL after 20 s
  local pid
  for pid in "${pids[@]}"; do kill -INT "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do
    for _ in $(seq 1 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.2; done
    kill -KILL "$pid" 2>/dev/null || true
    wait "$pid" 2>/dev/null || true
  done
  pids=()
}
trap stop_started EXIT
in_install roscore -p "$port" >"$WORK/roscore.log" 2>&1 &
pids+=($!)
if (in_install python3 "$INSTALL_DIR/lib/bdis_stereo/bdis_common.py" wait-master --timeout 30) \
    >"$WORK/wait_master.log" 2>&1; then
  in_install roslaunch bdis_stereo bdis_stereo.launch >"$WORK/roslaunch.log" 2>&1 &
  pids+=($!)
fi
check nodelet '
  # A subscriber to an output: then the nodelet subscribes to its inputs.
  timeout 60 rostopic echo -n 1 /stereo/disparity/header >"$WORK/disparity.txt" &
  echo_pid=$!
  for _ in $(seq 1 150); do
    rostopic info /stereo/left/image_rect 2>/dev/null | grep -q "/stereo/bdis_stereo_manager" && break
    sleep 0.2
  done
  rostopic info /stereo/left/image_rect
  rosbag play -q -d 1 "$WORK/seq.bag"
  wait "$echo_pid"
  cat "$WORK/disparity.txt"
  grep -q "frame_id: \"stereo_left_optical\"" "$WORK/disparity.txt"
  rostopic info /stereo/disparity | tee "$WORK/disparity_info.txt"
  grep -q "/stereo/bdis_stereo_manager" "$WORK/disparity_info.txt"'
stop_started
trap - EXIT

exit $status
