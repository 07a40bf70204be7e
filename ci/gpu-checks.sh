#!/usr/bin/env bash
# The correctness checks of BENCHMARKS-GPU.md, on a GPU (or any Vulkan device), in one command:
#
#   ci/gpu-checks.sh [--device NAME] [LOGDIR]        (NAME: NVIDIA by default; LOGDIR: gpu-checks)
#
# From the repository root, with build/raycast built and the corpus at $RAYCAST_CORPUS
# (else ../shared/corpus/cs1230). Each step's output goes to LOGDIR/STEP.log and its
# last lines to stdout; the summary at the end names every step that failed. Runs, in order
# of what a short lease most needs:
#   shader-test  every tests/shaders/*.toml case on the device, validation layer on
#   check        the device against the CPU build, every buffer bit for bit, on every corpus
#                scene and gen:recursive-spheres:8, for each AOV (color, depth, id, cost,
#                cost-all, normal), validation layer on
#   check-dekker, shader-test-dekker
#                the colour check and the harness again with the correction's residuals by
#                Dekker's product (RAYCAST_FMA_RESIDUALS=0), where the fma probe chose fma
#   check-no-shadows
#                the same without shadow rays at 160x120, our scenes and the stress scenes too
#                (where Mesa 22.3's lavapipe once stored a 0 normal beside mirror paths)
#   check-spp2   two samples a pixel on generated deep scenes
#   check-suite  the check suite's own binary (tests/check.rs, where ci/lent-gpu.sh carried it as
#                build/check-suite; skipped and said so otherwise) on the default device, which
#                is the GPU there: its fixed variants and RAYCAST_MUTANTS mutated scenes (2000
#                unless set) under random settings
#   orbit        `render --orbit 6` of recursiveSpheres4 on the device and the CPU build: the
#                same PNG files byte for byte
#   conformance  the course's reference renders, under each case's stated rule
#   fast         the fast kernel (--kernel fast) against the CPU build on every test_* scene at
#                512x384: at most k pixels a scene off by more than 2/255, k the cli suite's
#                FAST_KERNEL_MAX_PIXELS (tests/cli.rs, measured on lavapipe; read from there)
# Every step but `fast` runs the exact kernel (`check` always does; the others say --exact),
# as a GPU's default (--kernel auto) is the fast one.
#   preview-xvfb the preview under an Xvfb of its own (where Xvfb is installed or carried;
#                skipped and said so otherwise): a window (the device drawing apart from it
#                where another device, say a carried lavapipe, shows it), or the refusal of a
#                device that cannot present there (NVIDIA's driver: neither NV-GLX nor DRI3)
#                where none can, never a crash
# Exit status: the number of failed steps (0 when all pass).
set -u
device=NVIDIA
if [ "${1:-}" = --device ]; then device="$2"; shift 2; fi
logs="${1:-gpu-checks}"
corpus="${RAYCAST_CORPUS:-../shared/corpus/cs1230}"
raycast=build/raycast
[ -x "$raycast" ] || { echo "gpu-checks: $raycast is missing: build first (cmake --build build)" >&2; exit 100; }
[ -d "$corpus/test_efficiency" ] || { echo "gpu-checks: no corpus at $corpus: set RAYCAST_CORPUS" >&2; exit 100; }
mkdir -p "$logs"
failed=()

step() { # NAME COMMAND...: runs COMMAND, its output to $logs/NAME.log; notes a failure
  local name="$1"; shift
  local start=$SECONDS
  echo "== $name: ${*:1:7}${8:+ …}"
  if "$@" >"$logs/$name.log" 2>&1; then
    echo "   passed in $((SECONDS - start)) s"
  else
    echo "   FAILED (exit $?) in $((SECONDS - start)) s; the end of $logs/$name.log:"
    failed+=("$name")
  fi
  tail -n 4 "$logs/$name.log" | sed 's/^/   | /'
}

scenes=("$corpus"/test_*/*.xml gen:recursive-spheres:8)
check=("$raycast" check --device "$device" --validate --assets "$corpus")
step devices "$raycast" devices
step shader-test "$raycast" shader-test --device "$device" --validate
for aov in color depth id cost cost-all normal; do
  step "check-$aov" "${check[@]}" --aov "$aov" "${scenes[@]}"
done
# Where the probe gave the kernels fma residuals (FUSED_FMA), Dekker's too, which any other GPU gets.
step check-dekker env RAYCAST_FMA_RESIDUALS=0 "${check[@]}" "${scenes[@]}"
step shader-test-dekker env RAYCAST_FMA_RESIDUALS=0 "$raycast" shader-test --device "$device" --validate
step check-no-shadows "${check[@]}" --no-shadows --width 160 --height 120 \
  "${scenes[@]}" scenes/*.xml tests/scenes/stress/*.xml
step check-spp2 "$raycast" check --device "$device" --spp 2 --assets "$corpus" \
  gen:recursive-spheres:10 gen:recursive-cones:6 gen:recursive-cones:8 gen:recursive-cubes:6
check_suite() {
  [ -x build/check-suite ] || { echo "check-suite: no build/check-suite (ci/lent-gpu.sh checks carries it): skipped"; return 0; }
  RAYCAST_REPO="$PWD" RAYCAST_MUTANTS="${RAYCAST_MUTANTS:-2000}" build/check-suite
}
step check-suite check_suite
orbit() {
  local dir; dir="$(mktemp -d)"
  "$raycast" render "$corpus/test_efficiency/recursiveSpheres4.xml" --assets "$corpus" --device "$device" \
    --exact --orbit 6 -o "$dir/gpu.png" &&
  "$raycast" render "$corpus/test_efficiency/recursiveSpheres4.xml" --assets "$corpus" --backend cpu \
    --orbit 6 -o "$dir/cpu.png" || return 1
  local i differ=0
  for i in 000 001 002 003 004 005; do
    if cmp "$dir/gpu-$i.png" "$dir/cpu-$i.png"; then echo "orbit $i: the same bytes"; else differ=$((differ + 1)); fi
  done
  rm -rf "$dir"
  echo "orbit: $differ of 6 pictures differ"
  [ "$differ" = 0 ]
}
step orbit orbit
preview_xvfb() {
  command -v Xvfb >/dev/null || { echo "preview-xvfb: no Xvfb on PATH: skipped"; return 0; }
  local fifo out rc display
  fifo="$(mktemp -u)"; mkfifo "$fifo"
  Xvfb -displayfd 3 -noreset -nolisten tcp -screen 0 1280x1024x24 3>"$fifo" 2>/dev/null &
  local xvfb=$!
  read -r -t 10 display <"$fifo"; rm -f "$fifo"
  [ -n "$display" ] || { kill $xvfb 2>/dev/null; echo "preview-xvfb: Xvfb did not start"; return 1; }
  out="$(DISPLAY=":$display" timeout 60 "$raycast" preview --device "$device" --exact --frames 2 2>&1)"; rc=$?
  kill $xvfb 2>/dev/null; wait $xvfb 2>/dev/null
  echo "$out" | tail -3
  if [ $rc = 0 ]; then echo "preview-xvfb: the window showed the picture"; return 0; fi
  if [ $rc = 1 ] && grep -q "cannot present to this window" <<<"$out"; then
    echo "preview-xvfb: the device was refused with the reason (exit 1), as it cannot present there"; return 0
  fi
  echo "preview-xvfb: exit $rc (a crash is 128 + its signal)"; return 1
}
step preview-xvfb preview_xvfb
step conformance "$raycast" conformance "$corpus" --device "$device" --exact --validate --out-dir "$logs/conformance"
fast() {
  local k dir scene stem n worst=0 over=0
  k="$(sed -n 's/^const FAST_KERNEL_MAX_PIXELS: usize = \([0-9]*\);.*/\1/p' tests/cli.rs)"
  [ -n "$k" ] || { echo "fast: no FAST_KERNEL_MAX_PIXELS in tests/cli.rs"; return 1; }
  dir="$logs/fast"; rm -rf "$dir"; mkdir -p "$dir"
  local fast_scenes=()
  for g in unit intersect light efficiency feature dof area_light refract; do fast_scenes+=("$corpus/test_$g"/*.xml); done
  "$raycast" render -v --device "$device" --kernel fast --assets "$corpus" --out-dir "$dir/fast" "${fast_scenes[@]}" &&
  "$raycast" render --backend cpu --assets "$corpus" --out-dir "$dir/cpu" "${fast_scenes[@]}" || return 1
  for scene in "${fast_scenes[@]}"; do
    stem="$(basename "$scene" .xml)"
    n="$("$raycast" compare "$dir/fast/$stem.png" "$dir/cpu/$stem.png" --tolerance 2 --max-percent 100 --json |
      sed -n 's/.*"differing":\([0-9]*\).*/\1/p')"
    [ -n "$n" ] || { echo "fast: $stem: no comparison"; return 1; }
    echo "fast: $stem: $n pixels differ by more than 2/255 (rule: at most $k)"
    [ "$n" -gt "$worst" ] && worst=$n
    if [ "$n" -gt "$k" ]; then
      over=$((over + 1))
      "$raycast" compare "$dir/fast/$stem.png" "$dir/cpu/$stem.png" --tolerance 2 --max-percent 0 -o "$dir/$stem-diff.png"
    fi
  done
  echo "fast: worst $worst pixels; $over scenes over the rule (at most $k)"
  [ "$over" = 0 ]
}
step fast fast

if [ ${#failed[@]} = 0 ]; then
  echo "gpu-checks: every step passed on $device"
else
  echo "gpu-checks: ${#failed[@]} failed on $device: ${failed[*]}"
fi
exit ${#failed[@]}
