#!/usr/bin/env bash
# The node under load: the embedded sample as a bag replayed at 60 Hz
# (restamped at publish time) into bdis_stereo (nodelet in a manager pinned to
# one core; disparity, depth and points2 subscribed) and, in the same run, into
# stereo_image_proc (disparity + point_cloud2 nodelets, StereoBM and
# StereoSGBM) as the ROS reference. Prints one table; latency = arrival of a
# frame's last output at the bench (roscpp's receipt time) minus its stamp;
# cb p99 = the same up to the bench's callback, which adds the bench's own
# deserialising and queueing on its core; proc ms = the nodelet's own
# time per frame (median of its diagnostics' processing_ms_mean; decoding to
# publishing, not the transport); core = how busy the node's core was while
# measuring (/proc/stat, kernel work for it included). --size WxH replays the
# same scene rendered at that size instead (bdis_synth, 8 frames), e.g.
# --size 1920x1080 --rate 30 for an HD endoscope. --latencies DIR writes each
# row's per-frame latencies to DIR/<row>.txt (send time, then each output's).
#   scripts/bench_node.sh [--rate HZ] [--seconds S] [--size WxH] [--json FILE] [--latencies DIR]
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

RATE=60 SECONDS_MEASURED=20 JSON="" SIZE="" LATENCIES=""
usage="usage: $0 [--rate HZ] [--seconds S] [--size WxH] [--json FILE] [--latencies DIR]"
while [ $# -gt 0 ]; do
  case "$1" in
    --rate) RATE="$2"; shift 2 ;;
    --seconds) SECONDS_MEASURED="$2"; shift 2 ;;
    --json) JSON="$2"; shift 2 ;;
    --size) SIZE="$2"; shift 2 ;;
    --latencies) LATENCIES="$2"; shift 2 ;;
    *) echo "$usage" >&2; exit 2 ;;
  esac
done
if [ -n "$SIZE" ] && ! [[ "$SIZE" =~ ^[1-9][0-9]*x[1-9][0-9]*$ ]]; then
  echo "--size needs WIDTHxHEIGHT, got '$SIZE'" >&2
  echo "$usage" >&2
  exit 2
fi

prepare_ros_run
if [ -n "$LATENCIES" ]; then mkdir -p "$LATENCIES" && LATENCIES="$(cd "$LATENCIES" && pwd)"; fi

work="$(mktemp -d /tmp/bdis_bench_node.XXXXXX)"
trap 'rm -rf "$work"' EXIT
sample="$(bdis_common sample-dir)"
width=640 height=480
if [ -n "$SIZE" ]; then
  width="${SIZE%x*}" height="${SIZE#*x}"
  log "rendering the sample scene at ${width}x${height} (8 frames)"
  rosrun bdis_stereo bdis_synth --out "$work/scene" --width "$width" --height "$height" \
      --frames 8 --supersampling 1 --quiet
  sample="$work/scene"
fi
# stereo_image_proc searches a fixed range: the sample's disparities reach
# 80 px at 640 px wide, so 128 px scaled with the width (a multiple of 16).
disparity_range=$(( (128 * width / 640 + 15) / 16 * 16 ))
# One frame_id for both cameras: stereo_image_proc aborts on differing ones
# (image_geometry asserts), bdis_stereo accepts either.
rosrun bdis_stereo bdis_make_bag "$sample" "$work/sample.bag" --rate 30 --right-frame stereo_left_optical >/dev/null
json="${JSON:-$work/results.jsonl}"
: >"$json"

cores="$(nproc)"
node_core=$((cores > 1 ? 1 : 0))
printf '%-34s %9s %6s %6s %7s %11s %7s %7s %7s %7s %7s %7s %6s\n' "system (${width}x${height}, node on 1 core)" "rate" "sent" "out" "out %" "out rate" "p50 ms" "p95 ms" "p99 ms" "max ms" "proc ms" "cb p99" "core"
run_one() {  # label, launch args...
  local label="$1"; shift
  local port attempt
  for attempt in 1 2; do
    port="$(free_port)"
    ROS_MASTER_URI="http://127.0.0.1:$port" roslaunch -p "$port" bdis_stereo node_bench.launch \
        bag:="$work/sample.bag" label:="$label" json:="$json" rate:="$RATE" seconds:="$SECONDS_MEASURED" \
        node_core:="$node_core" bench_core:=0 ${LATENCIES:+latencies:="$LATENCIES/$label.txt"} "$@" \
        >"$work/$label.log" 2>&1 || true
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
run_one stereo_image_proc_bm system:=stereo_image_proc algorithm:=0 disparity_range:="$disparity_range"
run_one stereo_image_proc_sgbm system:=stereo_image_proc algorithm:=1 disparity_range:="$disparity_range"
