#!/usr/bin/env bash
# Soak test: 20,000 generated 320x240 frames through the nodelet in a manager
# (pinned to one core) at 100 Hz with disparity, depth and points2 subscribed;
# the manager's resident memory sampled every 2 s must stay flat after the
# warm-up (growth < 1 MB), and every frame sent must be accounted for: received
# or counted as lost in transport, paired, published or counted as dropped. Then the nodelet is unloaded and
# reloaded in the running manager 10 times: threads and memory must come back.
# Prints the figures and exits non-zero when a criterion fails.
#   scripts/soak.sh [--frames N] [--rate HZ]       (~4 min with the defaults)
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

FRAMES=20000 RATE=100 CYCLES=${BDIS_SOAK_CYCLES:-10} MAX_GROWTH_KB=1024
while [ $# -gt 0 ]; do
  case "$1" in
    --frames) FRAMES="$2"; shift 2 ;;
    --rate) RATE="$2"; shift 2 ;;
    *) echo "usage: $0 [--frames N] [--rate HZ]" >&2; exit 2 ;;
  esac
done

prepare_ros_run

work="$(mktemp -d /tmp/bdis_soak.XXXXXX)"
pids=()     # started in the background, stopped in reverse order on exit
loader=""
cleanup() {
  set +e  # a process that is already gone must not stop the clean-up
  [ -n "$loader" ] && kill -INT "$loader" 2>/dev/null
  for ((i = ${#pids[@]} - 1; i >= 0; i--)); do kill -INT "${pids[i]}" 2>/dev/null; done
  for _ in $(seq 50); do  # roscore stops its master and rosout on SIGINT: give it time
    alive=0
    for pid in "${pids[@]}" $loader; do kill -0 "$pid" 2>/dev/null && alive=1; done
    [ "$alive" = 0 ] && break
    sleep 0.2
  done
  for pid in "${pids[@]}"; do kill -KILL "$pid" 2>/dev/null; done
  [ -n "$loader" ] && kill -KILL "$loader" 2>/dev/null
  [ "${BDIS_KEEP_WORK:-}" = 1 ] && log "kept $work" || rm -rf "$work"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

port="$(free_port)"
export ROS_MASTER_URI="http://127.0.0.1:$port"
export ROS_LOG_DIR="$work/logs"

log "rendering 30 frames at 320x240 and writing a bag"
rosrun bdis_stereo bdis_synth --out "$work/seq" --width 320 --height 240 --frames 30 --quiet
rosrun bdis_stereo bdis_make_bag "$work/seq" "$work/seq.bag" --rate 30 >/dev/null

roscore -p "$port" >"$work/roscore.log" 2>&1 &
pids+=($!)
bdis_common wait-master --timeout 60

node_core=$(( $(nproc) > 1 ? 1 : 0 ))
taskset -c "$node_core" rosrun nodelet nodelet manager __name:=manager __ns:=/stereo >"$work/manager.log" 2>&1 &
manager=$!
pids+=("$manager")

# Loaded = its dynamic_reconfigure topics are advertised (the manager's list
# service needs nodelet's Python messages, which Debian does not package).
load_nodelet() {
  rosrun nodelet nodelet load bdis_stereo/BdisStereoNodelet /stereo/manager __name:=bdis_stereo \
      __ns:=/stereo >>"$work/loader.log" 2>&1 &
  loader=$!
  bdis_common wait-nodelet /stereo/bdis_stereo --timeout 60 && return 0
  log "manager log:"; tail -n 20 "$work/manager.log" >&2
  exit 1
}
unload_nodelet() {
  kill -INT "$loader"
  wait "$loader" 2>/dev/null || true  # 130 after SIGINT
  bdis_common wait-nodelet /stereo/bdis_stereo --unloaded --timeout 60 || exit 1
}
rss_kb() { awk '/^VmRSS/ {print $2}' "/proc/$manager/status"; }
threads() { ls "/proc/$manager/task" | wc -l; }

for _ in $(seq 100); do rosnode list 2>/dev/null | grep -qx /stereo/manager && break; sleep 0.2; done
sleep 2  # its ROS threads (spinners, xmlrpc, rosout) are up
threads_idle=$(threads)
load_nodelet

# ---- soak: RSS every 2 s while the frames go through -------------------------
log "soak: $FRAMES frames at $RATE Hz (about $((FRAMES / RATE + 10)) s)"
( start=$(date +%s); while kill -0 "$manager" 2>/dev/null; do
    echo "$(( $(date +%s) - start )) $(rss_kb)"; sleep 2; done ) >"$work/rss.txt" &
sampler=$!
pids+=("$sampler")
taskset -c 0 rosrun bdis_stereo bdis_node_bench --bag "$work/seq.bag" --label soak --rate "$RATE" \
    --frames "$FRAMES" --warmup 0 --outputs disparity,depth/image_rect,points2 --json "$work/soak.json" \
    >"$work/bench.log" 2>&1 || { tail -n 20 "$work/bench.log"; log "the bench failed"; exit 1; }
kill "$sampler"
alive=1; kill -0 "$manager" 2>/dev/null || alive=0
sleep 2  # one more diagnostics period: the nodelet's totals
timeout 20 rostopic echo -n 1 /diagnostics >"$work/diagnostics.txt" 2>&1 || true
unload_nodelet
# roscpp starts its global timer threads (wall, steady) on the first timer a
# nodelet creates and keeps them for the life of the process: the reference
# for "no thread left behind" is the count after the first unload.
threads_after_first=$(threads)

# ---- unload / reload in the running manager ---------------------------------
log "unloading and reloading the nodelet $CYCLES times"
cycle_rss=() cycle_threads=()
for i in $(seq "$CYCLES"); do
  load_nodelet
  rosrun bdis_stereo bdis_node_bench --bag "$work/seq.bag" --label cycle --rate 30 --seconds 1 --warmup 0.5 \
      >/dev/null 2>&1 || true
  unload_nodelet
  cycle_rss+=("$(rss_kb)")
  cycle_threads+=("$(threads)")
done

"$PYTHON_EXE" - "$work" "$FRAMES" "$MAX_GROWTH_KB" "$alive" "$threads_idle $threads_after_first" \
    "${cycle_rss[*]}" "${cycle_threads[*]}" <<'EOF'
import json, re, sys
work, frames, max_growth, alive, threads_ref, rss_cycles, thread_cycles = sys.argv[1:8]
threads_idle, threads_after_first = map(int, threads_ref.split())
frames, max_growth = int(frames), int(max_growth)
soak = json.loads(open(work + "/soak.json").read().splitlines()[-1])
samples = [tuple(map(int, l.split())) for l in open(work + "/rss.txt") if len(l.split()) == 2]
t_end = samples[-1][0]
warm = [rss for t, rss in samples if t >= min(20, t_end / 3)]  # after 20 s (shorter runs: a third)
# Flat = the high-water mark of the second half of the run (after warm-up) is
# not above the first half's. RSS moves by a few MB from sample to sample
# (images of 0.2-1.2 MB queued and freed, malloc arenas per thread); a leak
# raises the high-water mark, that noise does not.
half = len(warm) // 2
level_start, level_end = max(warm[:half] or warm[:1]), max(warm[half:])
growth = level_end - level_start
peak_growth = max(warm) - min(warm)
# rostopic echo of the DiagnosticArray: "key: frames_in" followed by "value: '123'".
diag = open(work + "/diagnostics.txt").read()
counts = {k: int(v) for k, v in re.findall(r"key: \"?(\w+)\"?\s+value: ['\"]?(\d+)['\"]?\s", diag)}
rss_cycles = list(map(int, rss_cycles.split()))
thread_cycles = list(map(int, thread_cycles.split()))
received = soak["received_total"]["disparity"]
checks = [
    ("manager alive after the soak", alive == "1"),
    ("frames sent = %d" % frames, soak["frames_sent_total"] == frames),
    ("left images received + counted as lost = sent (%s + %s)" % (counts.get("left_images"), counts.get("left_images_lost")),
     counts.get("left_images", -1) + counts.get("left_images_lost", -1) == frames),
    ("pairs formed = left images received (%s)" % counts.get("frames_in"),
     counts.get("frames_in") == counts.get("left_images")),
    ("pairs = published + dropped_busy (%s + %s)" % (counts.get("frames_out"), counts.get("dropped_busy")),
     counts.get("frames_in") == counts.get("frames_out", -1) + counts.get("dropped_busy", -1)),
    ("disparities received = published (%d)" % received, received == counts.get("frames_out")),
    ("no rejected frame, no error", counts.get("rejected") == 0 and counts.get("errors") == 0),
    ("RSS high-water mark, second half vs first half after warm-up: %+d kB < %d kB "
     "(range of the samples %d kB)" % (growth, max_growth, peak_growth), growth < max_growth)
    if t_end >= 80 else ("RSS not judged: %d s of soak, 80 s needed (more --frames)" % t_end, True),
    ("threads equal after each of %d reloads (%d)" % (len(thread_cycles), thread_cycles[0]),
     all(t == thread_cycles[0] for t in thread_cycles)),
    ("RSS over reloads 2..%d: %+d kB" % (len(rss_cycles), rss_cycles[-1] - rss_cycles[1]),
     rss_cycles[-1] - rss_cycles[1] < max_growth),
]
print("soak: %d frames (320x240, %s Hz), published %s, dropped_busy %s, lost before the nodelet %s, "
      "RSS high-water %d -> %d kB (halves after warm-up), %d samples; output rate %.1f Hz, latency p50 %.1f ms p99 %.1f ms"
      % (frames, soak["rate_hz"], counts.get("frames_out"), counts.get("dropped_busy"),
         counts.get("left_images_lost"), level_start, level_end,
         len(samples), soak["output_rate_hz"], soak["latency_ms_p50"], soak["latency_ms_p99"]))
print("reload cycles: RSS kB %s; threads %s (manager before any load: %d, after the soak's unload: %d;"
      " roscpp starts global timer threads on first use)" % (rss_cycles, thread_cycles, threads_idle,
                                                             threads_after_first))
ok = True
for name, passed in checks:
    print("  [%s] %s" % ("ok" if passed else "FAIL", name))
    ok &= passed
sys.exit(0 if ok else 1)
EOF
