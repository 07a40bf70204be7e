#!/usr/bin/env bash
# Issue 45's machine-readable line for the head of BENCHMARKS-GPU.md, measured
# on a lent GPU (docs/platforms.md#lent-gpu-machines) in one run beside an older
# binary (the issue's: d82e154's build/raycast, carried there):
#
#   ci/gpu-summary.sh [--device NAME] [--old OLD_RAYCAST] [--size WxH] [--frames N]
#
# prints the commands it ran, each figure's source, then
#   <!-- gpu-summary: commit=SHA; device=NAME; spheres4_1080p_all_mrays=N; spheres10_1080p_all_mrays=N;
#        frame_over_dispatch_1080p=R; preview_1080p_rest_fps=F; old_spheres4_1080p_all_mrays=N -->
# (one line). Rates count every ray of the frame (camera, shadow, mirror) over
# the dispatch: the device's timestamps where `bench` reports them, else the
# host's dispatch time (recording, submission, wait), which an older binary
# gives; each figure says which. frame_over_dispatch is recursiveSpheres4's
# whole frame (upload, dispatch, readback) over its dispatch. The preview's
# figure: depth 10 with shadows, a 1920x1080 window at rest (`preview
# --frames 12`, under Xvfb). --size replaces 1920x1080 (a dry run on lavapipe:
# --size 128x96); the keys keep their names.
source "$(dirname "$0")/common.sh"
device=() old="" size=1920x1080 frames=10
while [ $# -gt 0 ]; do
  case "$1" in
    --device) device=(--device "$2"); shift 2 ;;
    --old) old="$2"; shift 2 ;;
    --size) size="$2"; shift 2 ;;
    --frames) frames="$2"; shift 2 ;;
    *) echo "usage: ci/gpu-summary.sh [--device NAME] [--old OLD_RAYCAST] [--size WxH] [--frames N]" >&2; exit 2 ;;
  esac
done
RAYCAST="${RAYCAST:-$ROOT/build/raycast}"
CORPUS="${RAYCAST_CORPUS:-$ROOT/../shared/corpus/cs1230}"
[ -x "$RAYCAST" ] || { echo "gpu-summary: no $RAYCAST (build it first)" >&2; exit 1; }
[ -d "$CORPUS" ] || { echo "gpu-summary: no corpus at $CORPUS (RAYCAST_CORPUS)" >&2; exit 1; }
spheres4="$CORPUS/test_efficiency/recursiveSpheres4.xml"
w="${size%x*}" h="${size#*x}"

# Field $2 of bench's JSON line $1 as a number; empty where it is absent or null.
json_number() { json_field "$1" "$2" | tr -d ' ' | sed 's/^null$//'; }

# bench BINARY SCENE: its JSON line for the device at the size.
bench() {
  local cmd=("$1" bench "$2" --assets "$CORPUS" --width "$w" --height "$h" --frames "$frames" --warmup 2 --json "${device[@]}")
  echo "gpu-summary: ${cmd[*]}" >&2
  "${cmd[@]}" 2>/dev/null | grep -m1 '"frame_ms_median"' || { echo "gpu-summary: failed: ${cmd[*]}" >&2; exit 1; }
}

# rate LINE: every ray over the dispatch in M rays/s, and which dispatch time.
rate() {
  local rays dispatch source=device
  rays="$(json_number "$1" all_rays_per_frame)"
  dispatch="$(json_number "$1" device_dispatch_ms_median)"
  if [ -z "$dispatch" ]; then dispatch="$(json_number "$1" dispatch_ms_median)" source=host; fi
  awk -v r="$rays" -v t="$dispatch" -v s="$source" 'BEGIN { printf "%.0f %s %s\n", r / t / 1e3, s, t }'
}

line4="$(bench "$RAYCAST" "$spheres4")"
line10="$(bench "$RAYCAST" gen:recursive-spheres:10)"
read -r mrays4 src4 dispatch4 <<<"$(rate "$line4")"
read -r mrays10 src10 _ <<<"$(rate "$line10")"
frame4="$(json_number "$line4" frame_ms_median)"
ratio="$(awk -v f="$frame4" -v d="$dispatch4" 'BEGIN { printf "%.2f", f / d }')"
name="$(sed -n 's/.*"device": *"\([^"]*\)".*/\1/p' <<<"$line4" | sed 's/;/,/g')"

fps="–"
if command -v xvfb-run >/dev/null; then
  preview=("$RAYCAST" preview gen:recursive-spheres:10 --assets "$CORPUS" --width "$w" --height "$h" --frames 12 "${device[@]}")
  echo "gpu-summary: xvfb-run -a -s '-screen 0 $((w + 64))x$((h + 64))x24' ${preview[*]}" >&2
  out="$(xvfb-run -a -s "-screen 0 $((w + 64))x$((h + 64))x24" "${preview[@]}" 2>&1)" || { echo "$out" >&2; exit 1; }
  fps="$(sed -n 's/^at rest: .*, \([0-9.]*\) frames a second$/\1/p' <<<"$out" | head -1)"
  [ -n "$fps" ] || { echo "$out" >&2; echo "gpu-summary: the preview printed no 'at rest' line" >&2; exit 1; }
else
  echo "gpu-summary: no xvfb-run: preview_1080p_rest_fps is –" >&2
fi

old_mrays="–" old_src=""
if [ -n "$old" ]; then
  read -r old_mrays old_src _ <<<"$(rate "$(bench "$old" "$spheres4")")"
fi

echo "gpu-summary: rates by the $src4 dispatch time (depth 10: $src10${old:+; the older binary: $old_src}); $size; frame over dispatch: recursiveSpheres4" >&2
echo "<!-- gpu-summary: commit=${RAYCAST_COMMIT:-$(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null || echo unknown)}; device=$name; spheres4_1080p_all_mrays=$mrays4; spheres10_1080p_all_mrays=$mrays10; frame_over_dispatch_1080p=$ratio; preview_1080p_rest_fps=$fps; old_spheres4_1080p_all_mrays=$old_mrays -->"
