#!/usr/bin/env bash
# The benchmark command: builds the package if needed, then prints one table
# for this machine (CPU name, family / model, cache sizes and widest SIMD
# extension from /proc/cpuinfo and sysfs):
#  - per synthetic and per in-vivo sequence of the shared data folder (the
#    in-vivo frames carry a black rectification frame), the median over all its
#    frames (each timed several times) of the per-frame compute time of bdis
#    fast / balanced / accurate and OpenCV DIS fast, in the same run, pinned to
#    one core, single-threaded, and the ratio to DIS fast;
#  - image-size scaling on generated scenes (320x240 .. 1920x1080), ms and
#    ms per megapixel, balanced and DIS fast, the sizes taking turns round by
#    round, and the exponent e of a fit time ~ pixels^e over the sizes
#    (1 = linear); twice: frames back to back, and with the caches emptied
#    before each frame (a buffer of three times the L3 read, untimed), which
#    tells between-frame cache residency of the small frames from growth
#    inside a frame;
#  - instructions per frame (valgrind callgrind, one compute of the first pair
#    of synthetic_colon_diffuse, after a warm-up compute) for balanced and DIS
#    fast: a measure other load on the machine does not move; the same on the
#    generated scene at each size (frame 0, rendered by bdis_synth), per
#    megapixel, which shows whether the work grows with the pixel count;
#  - the node under load (scripts/bench_node.sh): the embedded sample as a bag
#    at 60 Hz through the nodelet in a manager on one core, and through
#    stereo_image_proc (StereoBM, SGBM) in the same run: share of frames
#    published, output rate, latency p50 / p95 / p99.
# Times are thread CPU time, so other processes on the core count little;
# compare them only as ratios within one run.
#
# usage: scripts/bench.sh [--rounds N] [--no-scaling] [--no-node] [--set NAME=VALUE ...]
#   BDIS_BENCH_CORE  core to pin to (default 1, or 0 on a one-core machine)
#   BDIS_WS_DIR      workspace (default _ws), BDIS_DATA_DIR data folder
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

BIN_DIR="$WS_DIR/devel/lib/bdis_stereo"
install_dependencies
if [ ! -x "$BIN_DIR/bdis_bench" ] || [ ! -x "$BIN_DIR/bdis_node_bench" ]; then
  build_package
fi
run_node=1 run_scaling=1
args=()
for a in "$@"; do
  if [ "$a" = "--no-node" ]; then run_node=0; else args+=("$a"); fi
  if [ "$a" = "--no-scaling" ]; then run_scaling=0; fi
done
set -- "${args[@]+"${args[@]}"}"
[ -x "$BIN_DIR/bdis_bench" ] || { log "bdis_bench was not built (is libbenchmark-dev installed?)"; exit 1; }

core="${BDIS_BENCH_CORE:-$([ "$(nproc)" -gt 1 ] && echo 1 || echo 0)}"
cpuinfo_field() { grep -m1 "^$1[[:space:]]*:" /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//'; }
cache_size() { cat "/sys/devices/system/cpu/cpu$core/cache/index$1/size" 2>/dev/null || echo "?"; }
cpu="$(cpuinfo_field 'model name')"
# A virtual machine's model name may be only the brand ("AMD EPYC"): family,
# model and the cache sizes tell instances apart, whose speeds differ.
family="$(cpuinfo_field 'cpu family')"
cpu_id="${family:+family $family model $(cpuinfo_field model); }"
simd=""
for flag in avx512f avx2 sse4_1 asimd; do
  grep -m1 -qw "$flag" /proc/cpuinfo && { simd="$flag"; break; }
done
echo "CPU: ${cpu:-unknown} (${cpu_id}L2 $(cache_size 2) per core, L3 $(cache_size 3); widest SIMD ${simd:-none}; $(nproc) cores online)"
echo "pinned to core $core with taskset, single-threaded"
echo

taskset -c "$core" "$BIN_DIR/bdis_bench" --table "$@"

node_rows() {
  local json
  json="$(mktemp)"
  BDIS_SKIP_BUILD=1 "$REPO_DIR/scripts/bench_node.sh" --json "$json" >/dev/null || true
  "$PYTHON_EXE" - "$json" <<'EOF'
import json, sys
for line in open(sys.argv[1]):
    r = json.loads(line)
    print("| node, %g Hz bag, node on one core: published at rate; latency p50 / p95 / p99 | %s | 640x480 "
          "| %d sent | %.1f %% at %.1f Hz | %.1f / %.1f / %.1f ms | |"
          % (r["rate_hz"], r["label"], r["frames_sent"], 100.0 * r["frames_out"] / max(1, r["frames_sent"]),
             r["output_rate_hz"], r["latency_ms_p50"], r["latency_ms_p95"], r["latency_ms_p99"]))
EOF
  rm -f "$json"
}

if ! command -v valgrind >/dev/null 2>&1; then
  echo "| instructions (callgrind) | valgrind not installed | | | | | |"
  [ "$run_node" = 1 ] && node_rows
  exit 0
fi
instructions() {  # method [bdis_bench options] -> instructions of one compute
  local out
  out="$(mktemp)"
  valgrind --tool=callgrind --instr-atstart=no --callgrind-out-file="$out" \
    "$BIN_DIR/bdis_bench" --one-frame "$1" "${@:2}" >/dev/null 2>&1
  awk '/^totals:/ {print $2}' "$out"
  rm -f "$out"
}
# --set changes bdis_balanced here too.
set_args=()
while [ $# -gt 0 ]; do
  [ "$1" = "--set" ] && [ $# -gt 1 ] && set_args+=("--set" "$2") && shift
  shift
done
bdis="$(instructions bdis_balanced "${set_args[@]}")"
dis="$(instructions dis_fast)"
awk -v b="$bdis" -v d="$dis" 'BEGIN {
  mpix = 640 * 480 / 1e6
  printf "| instructions (callgrind), first pair of synthetic_colon_diffuse | bdis balanced | 640x480 | 1 | %.1f M | %.1f M | %.2f |\n", b / 1e6, b / 1e6 / mpix, b / d
  printf "| instructions (callgrind), first pair of synthetic_colon_diffuse | DIS fast | 640x480 | 1 | %.1f M | %.1f M | 1.00 |\n", d / 1e6, d / 1e6 / mpix
}'
# The generated scene at each size of the scaling rows, rendered outside
# valgrind (a 1920x1080 frame takes seconds natively, minutes under it).
scenes="$(mktemp -d /tmp/bdis_bench_scenes.XXXXXX)"
trap 'rm -rf "$scenes"' EXIT
for size in $([ "$run_scaling" = 1 ] && echo 320x240 640x480 1280x720 1920x1080); do
  "$BIN_DIR/bdis_synth" --out "$scenes/$size" --frames 1 --width "${size%x*}" --height "${size#*x}" >/dev/null 2>&1
  pair=(--pair "$scenes/$size/left/000000.png" "$scenes/$size/right/000000.png")
  # Searched down to level 1 at every size: how the kernels scale.
  bdis="$(instructions bdis_balanced "${pair[@]}" --set finest_level=1 "${set_args[@]}")"
  dis="$(instructions dis_fast "${pair[@]}")"
  awk -v b="$bdis" -v d="$dis" -v size="$size" 'BEGIN {
    split(size, wh, "x"); mpix = wh[1] * wh[2] / 1e6
    printf "| instructions (callgrind), generated scene frame 0 (scaling) | bdis balanced, finest level 1 | %s | 1 | %.1f M | %.1f M | %.2f |\n", size, b / 1e6, b / 1e6 / mpix, b / d
    printf "| instructions (callgrind), generated scene frame 0 (scaling) | DIS fast | %s | 1 | %.1f M | %.1f M | 1.00 |\n", size, d / 1e6, d / 1e6 / mpix
  }'
done
if [ "$run_node" = 1 ]; then node_rows; fi
