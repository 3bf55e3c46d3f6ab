#!/usr/bin/env bash
# Scores the matcher on the generated failure scenes, each variant at two
# seeds, beside the shared synthetic sequences, in one bdis_eval run: whether a
# change carries over to scenes it was not chosen on, or only fits the shared
# frames. The renders are cached (again only when bdis_synth changes).
#
# usage: scripts/eval_generated.sh [--variants "V ..."] [--seeds "S ..."] [--frames N]
#                                  [--size WxH] [--no-shared] [--] [bdis_eval options]
#   --variants   bdis_synth variants (default: all but sample)
#   --seeds      seeds, each variant rendered once per seed (default: 7 11)
#   --frames     frames per render (default: 8)
#   --size       frame size (default 640x480; the focal length scales with the
#                width, so the scene is the same); other sizes are named
#                VARIANT_sSEED_WxH
#   --no-shared  only the generated scenes, not $BDIS_DATA_DIR's synthetic_colon_*
#   the rest goes to bdis_eval (default: --methods bdis), e.g.
#   scripts/eval_generated.sh -- --methods bdis,dis_fast --set patch_size=6
# Sequences are named VARIANT_sSEED in bdis_eval's tables.
#   BDIS_GENERATED_DIR  render cache (default _ws/generated)
#   BDIS_SKIP_BUILD=1   use the workspace as it is
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

BIN_DIR="$WS_DIR/devel/lib/bdis_stereo"
CACHE_DIR="${BDIS_GENERATED_DIR:-$WS_DIR/generated}"

variants="" seeds="7 11" frames=8 size=640x480 shared=1
while [ $# -gt 0 ]; do
  case "$1" in
    --variants) variants="${2:?--variants needs a list}"; shift 2 ;;
    --seeds) seeds="${2:?--seeds needs a list}"; shift 2 ;;
    --frames) frames="${2:?--frames needs a number}"; shift 2 ;;
    --size) size="${2:?--size needs WxH}"; shift 2 ;;
    --no-shared) shared=0; shift ;;
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

# A render is reused while bdis_synth and the settings are the same.
[[ "$size" =~ ^[0-9]+x[0-9]+$ ]] || { log "--size must be WxH, e.g. 1280x720"; exit 2; }
width="${size%x*}" height="${size#*x}"
suffix="" size_args=""
if [ "$size" != 640x480 ]; then
  suffix="_$size"
  size_args="--width $width --height $height"
fi
synth_id="$(sha256sum "$BIN_DIR/bdis_synth" | cut -c1-16)"
sequences=()
for variant in $variants; do
  for seed in $seeds; do
    dir="$CACHE_DIR/${variant}_s${seed}${suffix}"
    stamp="$synth_id --variant $variant --seed $seed --frames $frames${size_args:+ $size_args}"
    if [ "$(cat "$dir/render.stamp" 2>/dev/null)" != "$stamp" ]; then
      log "rendering $variant, seed $seed, $frames frames"
      rm -rf "$dir"
      mkdir -p "$dir"
      # shellcheck disable=SC2086  # size_args is empty or four words
      "$BIN_DIR/bdis_synth" --out "$dir" --variant "$variant" --seed "$seed" --frames "$frames" $size_args \
        --overwrite >"$dir/render.log" 2>&1 || { cat "$dir/render.log" >&2; rm -rf "$dir"; log "bdis_synth failed"; exit 1; }
      echo "$stamp" >"$dir/render.stamp"
    fi
    sequences+=("$dir")
  done
done
if [ "$shared" = 1 ]; then
  for name in synthetic_colon_diffuse synthetic_colon_specular; do
    if [ -d "$BDIS_DATA_DIR/$name" ]; then
      sequences+=("$BDIS_DATA_DIR/$name")
    else
      log "$BDIS_DATA_DIR/$name not found: scoring the generated scenes only"
    fi
  done
fi

exec "$BIN_DIR/bdis_eval" "${sequences[@]}" "$@"
