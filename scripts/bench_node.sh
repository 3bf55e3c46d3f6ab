#!/usr/bin/env bash
# The node under load: the embedded sample as a bag replayed at 60 Hz
# (restamped at publish time) into bdis_stereo (nodelet in a manager pinned to
# one core; disparity, depth and points2 subscribed) and, in the same run, into
# stereo_image_proc (disparity + point_cloud2 nodelets, StereoBM and
# StereoSGBM) as the ROS reference. Prints one table; latency = arrival of a
# frame's last output at the bench minus its stamp.
#   scripts/bench_node.sh [--rate HZ] [--seconds S] [--json FILE]
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

RATE=60 SECONDS_MEASURED=20 JSON=""
while [ $# -gt 0 ]; do
  case "$1" in
    --rate) RATE="$2"; shift 2 ;;
    --seconds) SECONDS_MEASURED="$2"; shift 2 ;;
    --json) JSON="$2"; shift 2 ;;
    *) echo "usage: $0 [--rate HZ] [--seconds S] [--json FILE]" >&2; exit 2 ;;
  esac
done

prepare_ros_run

work="$(mktemp -d /tmp/bdis_bench_node.XXXXXX)"
trap 'rm -rf "$work"' EXIT
sample="$(bdis_common sample-dir)"
# One frame_id for both cameras: stereo_image_proc aborts on differing ones
# (image_geometry asserts), bdis_stereo accepts either.
rosrun bdis_stereo bdis_make_bag "$sample" "$work/sample.bag" --rate 30 --right-frame stereo_left_optical >/dev/null
json="${JSON:-$work/results.jsonl}"
: >"$json"

cores="$(nproc)"
node_core=$((cores > 1 ? 1 : 0))
printf '%-34s %9s %6s %6s %7s %11s %7s %7s %7s %7s\n' "system (640x480, node on 1 core)" "rate" "sent" "out" "out %" "out rate" "p50 ms" "p95 ms" "p99 ms" "max ms"
run_one() {  # label, launch args...
  local label="$1"; shift
  local port attempt
  for attempt in 1 2; do
    port="$(free_port)"
    ROS_MASTER_URI="http://127.0.0.1:$port" roslaunch -p "$port" bdis_stereo node_bench.launch \
        bag:="$work/sample.bag" label:="$label" json:="$json" rate:="$RATE" seconds:="$SECONDS_MEASURED" \
        node_core:="$node_core" bench_core:=0 "$@" >"$work/$label.log" 2>&1 || true
    grep -E "^$label " "$work/$label.log" && return 0
    # stereo_image_proc's manager sometimes aborts while two nodelets load
    # image_transport plugins at once ("no factory exists"): once more.
    log "$label: no result (attempt $attempt); log tail:"
    tail -n 8 "$work/$label.log" >&2
  done
  printf '%-34s %9s\n' "$label" "failed (see above)"
}
run_one bdis_balanced system:=bdis preset:=balanced
run_one bdis_fast system:=bdis preset:=fast
run_one stereo_image_proc_bm system:=stereo_image_proc algorithm:=0
run_one stereo_image_proc_sgbm system:=stereo_image_proc algorithm:=1
