# Shared by scripts/test.sh (and later scripts): install what is missing, build
# the package in a catkin workspace under _ws/ (ignored by git).
# Sourced, not run.

set -euo pipefail

REPO_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
WS_DIR="${BDIS_WS_DIR:-$REPO_DIR/_ws}"
# The shared stereo sequences, for the tests, the benchmarks and the demo's --data.
export BDIS_DATA_DIR="${BDIS_DATA_DIR:-$REPO_DIR/../shared/data}"
# Debian's python has catkin_pkg; a pyenv or venv python on PATH does not.
export PATH="/usr/bin:$PATH"
PYTHON_EXE=/usr/bin/python3

log() { printf '\033[1m[bdis]\033[0m %s\n' "$*" >&2; }

# Debian 12 ships ROS 1 itself; on Ubuntu 20.04 the packages come from ROS Noetic.
DEBIAN_PACKAGES=(
  catkin python3-catkin-pkg ros-base-dev libopencv-dev
  libgtest-dev googletest libbenchmark-dev
  # the package's lint (scripts/test.sh): catkin_lint, and rosdep with Debian's map of the ROS keys
  catkin-lint python3-rosdep2
  # ROS layer: nodelet, its build and run dependencies, launch and bag tools
  libnodelet-dev libnodeletlib-dev libnodeletlib-tools pluginlib-dev libimage-transport-dev
  libmessage-filters-dev libimage-geometry-dev libstereo-msgs-dev libtf2-dev libtf2-ros-dev
  libdiagnostic-updater-dev python3-dynamic-reconfigure libdynamic-reconfigure-config-init-mutex-dev
  # rectify:=true: the image_proc/rectify nodelet (its package.xml in ros-image-proc;
  # its nodelet_plugins.xml and the libimage_proc.so pluginlib loads in the -dev package)
  ros-image-proc libimage-proc-dev
  rosbash python3-roslaunch python3-rosbag python3-rospy python3-yaml python3-numpy python3-opencv
  # rostests: the test nodes are Python
  librostest-dev python3-rostest python3-sensor-msgs python3-stereo-msgs python3-geometry-msgs
  python3-std-msgs python3-tf2-msgs python3-diagnostic-msgs python3-rosgraph-msgs
  # the demo (scripts/bdis_demo) and its rviz test under a virtual display
  python3-catkin rviz xvfb imagemagick libgl1-mesa-dri
  # benchmarks (scripts/bench.sh, bench_node.sh): bag reading, the ROS reference, callgrind
  librosbag-storage-dev libstereo-image-proc-dev valgrind
  # fuzzer (scripts/fuzz.sh): clang and its libFuzzer runtime (only recommended by clang)
  clang-14 libclang-rt-14-dev
)

sudo_if_needed() {
  if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi
}

install_dependencies() {
  if [ -f /opt/ros/noetic/setup.bash ]; then
    # Ubuntu 20.04 + Noetic: rosdep resolves package.xml.
    # shellcheck disable=SC1091
    set +u; source /opt/ros/noetic/setup.bash; set -u
    if ! rosdep check --from-paths "$REPO_DIR" --ignore-src -q >/dev/null 2>&1; then
      log "installing dependencies with rosdep"
      rosdep install --from-paths "$REPO_DIR" --ignore-src -y -q
    fi
    # Not in package.xml (no rosdep key of the package needs them): Google
    # Benchmark for bdis_bench, catkin_lint for the lint case of test.sh.
    local extra
    for extra in libbenchmark-dev python3-catkin-lint; do
      if ! dpkg -s "$extra" >/dev/null 2>&1; then
        sudo_if_needed env DEBIAN_FRONTEND=noninteractive apt-get install -y -q "$extra" || true
      fi
    done
    return
  fi
  local missing=()
  for pkg in "${DEBIAN_PACKAGES[@]}"; do
    dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    log "installing ${missing[*]}"
    sudo_if_needed env DEBIAN_FRONTEND=noninteractive apt-get update -q
    sudo_if_needed env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}"
  fi
}

# The package in the workspace: a directory of links to the repository's
# top-level entries, all but the workspace itself. (A link to the whole
# repository would put _ws/ inside its own package: a symlink loop through
# which roslaunch and rosrun find every file many times and refuse to run.)
link_package_source() {
  local pkg="$WS_DIR/src/bdis_stereo" ws_real entry
  mkdir -p "$WS_DIR/src"
  # The workspace lies inside the checkout: tools that walk the package's
  # folder (catkin_lint, catkin's package search) leave it out.
  touch "$WS_DIR/CATKIN_IGNORE"
  [ -L "$pkg" ] && rm "$pkg"
  mkdir -p "$pkg"
  find "$pkg" -maxdepth 1 -type l ! -exec test -e {} \; -delete  # entries gone from the repo
  ws_real="$(cd "$WS_DIR" && pwd -P)"
  for entry in "$REPO_DIR"/*; do
    [ "$(cd "$entry" 2>/dev/null && pwd -P)" = "$ws_real" ] && continue
    case "$(basename "$entry")" in
      _ws|build|out) rm -f "$pkg/$(basename "$entry")"; continue ;;  # build output (.gitignore), maybe another workspace
    esac
    ln -sfn "$entry" "$pkg/$(basename "$entry")"
  done
}

build_package() {
  link_package_source
  if [ -f /opt/ros/noetic/setup.bash ]; then
    set +u; source /opt/ros/noetic/setup.bash; set -u
  fi
  log "building in $WS_DIR"
  (cd "$WS_DIR" && catkin_make -DPYTHON_EXECUTABLE="$PYTHON_EXE" -DCMAKE_BUILD_TYPE=Release \
     -j"$(nproc)" "$@" >"$WS_DIR/build.log" 2>&1) || { tail -n 60 "$WS_DIR/build.log"; log "build failed (full log: $WS_DIR/build.log)"; return 1; }
}

# Removes DIR and everything under it from the colon-separated lists in the
# named variables (PATH, LD_LIBRARY_PATH, ...); a list left empty is unset.
drop_from_path_lists() {
  local dir="$1" var entry
  shift
  for var in "$@"; do
    local kept=() entries=()
    IFS=: read -ra entries <<<"${!var:-}"
    for entry in "${entries[@]}"; do
      case "$entry" in "$dir" | "$dir"/*) ;; *) kept+=("$entry") ;; esac
    done
    if [ ${#kept[@]} -gt 0 ]; then export "$var=$(IFS=:; echo "${kept[*]}")"; else unset "$var"; fi
  done
}

source_workspace() {
  set +u
  # shellcheck disable=SC1091
  source "$WS_DIR/devel/setup.bash"
  set -u
}

# For the commands that start ROS processes (demo, node benchmark, soak):
# install and build (BDIS_SKIP_BUILD=1: use the workspace as it is), source
# it, and keep ROS on loopback.
prepare_ros_run() {
  if [ "${BDIS_SKIP_BUILD:-}" != 1 ]; then
    install_dependencies
    build_package
  fi
  source_workspace
  ros_on_loopback
}

# ROS nodes started from here talk over loopback only.
ros_on_loopback() {
  export ROS_IP=127.0.0.1
  unset ROS_HOSTNAME
}

# run_rostest TEST_FILE RESULTS_DIR [WHAT]: one test/ros/*.test under rostest
# (a master of its own on a free port), its output in
# RESULTS_DIR/rostest-NAME.log, whose end is shown when it fails (status 1).
# WHAT, if given, names the run in the messages.
run_rostest() {
  local name rostest_log
  name="$(basename "$1" .test)"
  rostest_log="$2/rostest-$name.log"
  log "rostest $name.test${3:+ ($3)}"
  if ! rostest --results-base-dir "$2" bdis_stereo "$name.test" >"$rostest_log" 2>&1; then
    tail -n 40 "$rostest_log"
    log "rostest $name.test failed${3:+ ($3)} (full log: $rostest_log)"
    return 1
  fi
}

# junit_case OUT.xml SUITE NAME [...]: one JUnit test case (scripts/junit_case.py).
junit_case() {
  "$PYTHON_EXE" "$REPO_DIR/scripts/junit_case.py" "$@"
}

# The Python helpers shared with bdis_demo, bdis_make_bag and the tests
# (scripts/bdis_common.py): free-port, sample-dir, wait-master, wait-nodelet.
bdis_common() {
  "$PYTHON_EXE" "$REPO_DIR/scripts/bdis_common.py" "$@"
}

# A TCP port free on loopback now (for a master of our own).
free_port() { bdis_common free-port; }
