#!/usr/bin/env bash
# Scores the matcher on the generated failure scenes, each variant at two
# seeds, beside the shared synthetic sequences, in one bdis_eval run: whether a
# change carries over to scenes it was not chosen on, or only fits the shared
# frames. The renders are cached (again only when bdis_synth changes).
#
# usage: scripts/eval_generated.sh [--variants "V ..."] [--seeds "S ..."] [--frames N]
#                                  [--size WxH] [--coded "V ..."] [--coded-seeds "S ..."]
#                                  [--jpeg-quality Q] [--no-shared] [--invivo]
#                                  [--] [bdis_eval options]
#   --variants     bdis_synth variants (default: all but sample)
#   --seeds        seeds, each variant rendered once per seed (default: 7 11)
#   --frames       frames per render (default: 8)
#   --size         frame size (default 640x480; the focal length scales with the
#                  width, so the scene is the same); other sizes are named
#                  VARIANT_sSEED_WxH
#   --coded        variants rendered once more with block-coded views (each view
#                  stored as a JPEG of --jpeg-quality, default 75), named
#                  VARIANT_sSEED_qQ, at the seeds of --coded-seeds (default: --seeds)
#   --no-shared    only the generated scenes, not $BDIS_DATA_DIR's synthetic_colon_*
#   --invivo       also $BDIS_DATA_DIR's invivo_hamlyn_a and _b (no ground truth:
#                  bdis_eval scores the strips along their rectification border)
#   the rest goes to bdis_eval (default: --methods bdis), e.g.
#   scripts/eval_generated.sh -- --methods bdis,dis_fast --set patch_size=6
# Sequences are named VARIANT_sSEED in bdis_eval's tables. scripts/eval_summary.py
# condenses a run's --json (or compares two). The 54 sets of docs/method.md ("The
# blurred step cue") and the in-vivo sequences:
#   scripts/eval_generated.sh --seeds "7 11 13 17 19" --coded "tube dark_tube instrument specular" \
#     --coded-seeds "7 11 19" --invivo -- --methods bdis --set compute_variance=true --json run.json
#   BDIS_GENERATED_DIR  render cache (default _ws/generated)
#   BDIS_SKIP_BUILD=1   use the workspace as it is
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

BIN_DIR="$WS_DIR/devel/lib/bdis_stereo"
CACHE_DIR="${BDIS_GENERATED_DIR:-$WS_DIR/generated}"

variants="" seeds="7 11" frames=8 size=640x480 shared=1 invivo=0
coded="" coded_seeds="" quality=75
while [ $# -gt 0 ]; do
  case "$1" in
    --variants) variants="${2:?--variants needs a list}"; shift 2 ;;
    --seeds) seeds="${2:?--seeds needs a list}"; shift 2 ;;
    --frames) frames="${2:?--frames needs a number}"; shift 2 ;;
    --size) size="${2:?--size needs WxH}"; shift 2 ;;
    --coded) coded="${2:?--coded needs a list}"; shift 2 ;;
    --coded-seeds) coded_seeds="${2:?--coded-seeds needs a list}"; shift 2 ;;
    --jpeg-quality) quality="${2:?--jpeg-quality needs a number}"; shift 2 ;;
    --no-shared) shared=0; shift ;;
    --invivo) invivo=1; shift ;;
    -h | --help) sed -n '2,/^[^#]/s/^# \{0,1\}//p' "$0"; exit 0 ;;
    --) shift; break ;;
    *) break ;;
  esac
done
[ $# -gt 0 ] || set -- --methods bdis

if [ "${BDIS_SKIP_BUILD:-}" != 1 ] && { [ ! -x "$BIN_DIR/bdis_synth" ] || [ ! -x "$BIN_DIR/bdis_eval" ]; }; then
  install_dependencies
  build_package
fi
for tool in bdis_synth bdis_eval; do
  [ -x "$BIN_DIR/$tool" ] || { log "$BIN_DIR/$tool is missing: build the package first"; exit 1; }
done
if [ -z "$variants" ]; then
  # Every variant bdis_synth names but the demo's sample (the defaults).
  variants="$("$BIN_DIR/bdis_synth" --list-variants | grep -vx 'sample' | tr '\n' ' ')"
fi

[[ "$size" =~ ^[0-9]+x[0-9]+$ ]] || { log "--size must be WxH, e.g. 1280x720"; exit 2; }
[[ "$quality" =~ ^[0-9]+$ ]] && [ "$quality" -ge 1 ] && [ "$quality" -le 100 ] ||
  { log "--jpeg-quality must be 1..100"; exit 2; }
[ -n "$coded_seeds" ] || coded_seeds="$seeds"
width="${size%x*}" height="${size#*x}"
suffix="" size_args=""
if [ "$size" != 640x480 ]; then
  suffix="_$size"
  size_args="--width $width --height $height"
fi
synth_id="$(sha256sum "$BIN_DIR/bdis_synth" | cut -c1-16)"
sequences=()
# render VARIANT SEED [QUALITY]: the scene into the cache unless it is there
# from the same bdis_synth and settings (a render is reused while both are the
# same); its directory joins the sequences.
render() {
  local variant="$1" seed="$2" coding="${3:+_q$3}" coding_args="${3:+--jpeg-quality $3}"
  local dir="$CACHE_DIR/${variant}_s${seed}${coding}${suffix}"
  local stamp="$synth_id --variant $variant --seed $seed --frames $frames${size_args:+ $size_args}${coding_args:+ $coding_args}"
  if [ "$(cat "$dir/render.stamp" 2>/dev/null)" != "$stamp" ]; then
    log "rendering $variant, seed $seed, $frames frames${3:+, JPEG quality $3}"
    rm -rf "$dir"
    mkdir -p "$dir"
    # shellcheck disable=SC2086  # size_args and coding_args are empty or whole words
    "$BIN_DIR/bdis_synth" --out "$dir" --variant "$variant" --seed "$seed" --frames "$frames" $size_args \
      $coding_args --overwrite >"$dir/render.log" 2>&1 || { cat "$dir/render.log" >&2; rm -rf "$dir"; log "bdis_synth failed"; exit 1; }
    echo "$stamp" >"$dir/render.stamp"
  fi
  sequences+=("$dir")
}
for variant in $variants; do
  for seed in $seeds; do render "$variant" "$seed"; done
done
for variant in $coded; do
  for seed in $coded_seeds; do render "$variant" "$seed" "$quality"; done
done
# shared_sequences NAME...: those of $BDIS_DATA_DIR join the sequences; a missing one is named.
shared_sequences() {
  local name
  for name in "$@"; do
    if [ -d "$BDIS_DATA_DIR/$name" ]; then
      sequences+=("$BDIS_DATA_DIR/$name")
    else
      log "$BDIS_DATA_DIR/$name not found: scoring without it"
    fi
  done
}
if [ "$shared" = 1 ]; then shared_sequences synthetic_colon_diffuse synthetic_colon_specular; fi
if [ "$invivo" = 1 ]; then shared_sequences invivo_hamlyn_a invivo_hamlyn_b; fi

exec "$BIN_DIR/bdis_eval" "${sequences[@]}" "$@"
