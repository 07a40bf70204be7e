#!/usr/bin/env bash
# Regenerates BENCHMARKS.md in one command:
#
#   ci/benchmarks.sh [--no-build] [--only TEXT] [--skip TEXT] [FILE]     (FILE: BENCHMARKS.md by default)
#
# Every block of FILE that opens with `<!-- bench: COMMAND -->` and closes
# with `<!-- /bench -->` is replaced by what COMMAND prints, run from the
# repository root; the prose around the blocks is kept. COMMAND may use
# $CORPUS (RAYCAST_CORPUS, else ../shared/corpus/cs1230). Builds
# build/raycast first unless --no-build. With --only TEXT, only the blocks
# whose COMMAND contains TEXT are run again; the others stay as they are.
# With --skip TEXT, the blocks whose COMMAND contains TEXT stay as they are
# (a lent GPU's `checks` pack has no Xvfb for the preview's blocks).
#
# RAYCAST_COMMIT names the commit in the machine block where the tree's .git
# is not its own (a copy sent to a GPU machine). A block whose COMMAND uses
# $LAVAPIPE_ICD (a second driver's manifest, `unpack-driver` below) is kept
# as it is unless LAVAPIPE_ICD names such a file.
#
# Helpers that print blocks of their own:
#   ci/benchmarks.sh machine            the machine: CPU, cores, memory, Vulkan device, Mesa, load
#   ci/benchmarks.sh wall [--max-primitives N] [--device NAME] SCENE...
#                                       `build/raycast render` wall time per scene (median of 3
#                                       runs, /usr/bin/time) and peak RSS: the whole command,
#                                       as the issue's targets and POV-Ray's times are.
#                                       SCENE is a file or gen:FAMILY:DEPTH.
#   ci/benchmarks.sh preview [--at-rest] [PREVIEW OPTION...] SCENE...  (an option's value after =)
#                                       the preview's frame rate while the camera turns
#                                       (`raycast preview --frames 12 --moving 11` under
#                                       xvfb-run): the steering resolution and its rate;
#                                       with --at-rest, without --moving: whole samples
#                                       at the picture's size.
#   ci/benchmarks.sh povray [--rounds N] SCENE...
#                                       raycast's whole `render` (the device, then --backend cpu)
#                                       and POV-Ray 3.7 on the scene `raycast pov` writes, in
#                                       turn, N rounds (5): median wall times, their ratios, peak
#                                       RSS. The peer issue 7 names, measured beside raycast.
#   ci/benchmarks.sh mitsuba [--rounds N] SCENE...
#                                       raycast's CPU build beside Mitsuba 3 scalar_rgb on the
#                                       scene `raycast mitsuba` writes, 512x384, 1 spp, shadows
#                                       on, mirrors and textures off, the same thread count:
#                                       warm frames (N timed after 1 untimed, medians, rays a
#                                       pixel each side) and N whole commands in turn (median
#                                       wall times), the ratios Mitsuba / raycast. Mitsuba runs
#                                       from build/mitsuba-venv (made with pip the first time;
#                                       MITSUBA_PYTHON names another python with mitsuba).
#   ci/benchmarks.sh peers [--rounds N] SCENE...
#                                       the povray table, then the mitsuba table, in one run.
#   ci/benchmarks.sh explain SCENE...
#                                       `raycast explain` wall time per scene (median of 3) at
#                                       512x384 on a picture drawn with the specular term left
#                                       out of a copy of the shaders (every variant drawn on
#                                       the CPU build), and its first finding.
#   ci/benchmarks.sh passes [--all] SCENE...
#                                       `build/raycast render SCENE --aov cost --backend cpu`:
#                                       the passes of each camera ray's walk through the
#                                       hierarchy (mean, median, 90th and 99th percentiles,
#                                       most), against ln N; with --all (`--aov cost-all`)
#                                       every ray's of the pixel summed. Counts, not times.
#   ci/benchmarks.sh division [--device NAME] [--spp N] [--rounds N] SCENE...
#                                       `build/raycast render` dispatch medians of the exact
#                                       kernel's division correction: residuals as the fma
#                                       probe chose, Dekker's, and no correction; and of the
#                                       fast kernel (--kernel fast), in turn.
#   ci/benchmarks.sh profile [--device NAME] [--frames N] SCENE...
#                                       `build/raycast bench --json` per scene at 1920x1080 and
#                                       512x384 under five settings (the exact kernel, all on;
#                                       the fast kernel; no shadows; no mirrors; neither, the
#                                       last three on the fast kernel): the frame, the host's dispatch and
#                                       the device's timestamps per phase (clears, dispatch,
#                                       readback copy), rays a second by frame and by the
#                                       device's dispatch; then each scene's kernel statistics
#                                       (`bench --kernel-stats`).
#                                       PROFILE_SIZES="W1xH1 ..." replaces the two sizes (a dry run
#                                       on lavapipe).
#   ci/benchmarks.sh checks [--device NAME] SCENE...
#                                       `build/raycast check` per scene: how many pixels
#                                       differ between the device and the CPU build, per
#                                       buffer (0 everywhere on lavapipe; counts on GPUs).
#   ci/benchmarks.sh drivers [--rounds N] ICD.json SCENE...
#                                       `build/raycast render` with the Vulkan driver the
#                                       loader finds and with VK_DRIVER_FILES=ICD.json, in
#                                       turn: medians of the whole command and of the
#                                       compile and dispatch, and whether the PNGs are the same bytes
#                                       (another Mesa's lavapipe beside the installed one).
#   ci/benchmarks.sh settings [--rounds N] 'VAR=V ...' 'VAR=V ...' SCENE...
#                                       the same table for two environments of `render` on
#                                       one driver (RAYCAST_SHADER_OBJECTS=1 against =0).
#   ci/benchmarks.sh builds [--rounds N] OLD NEW SCENE...
#                                       the same table for two raycast binaries in turn
#                                       (OLD: a build of an earlier commit, copied aside),
#                                       with each round's pair: how often NEW was faster.
#   ci/benchmarks.sh unpack-driver DEB DIR
#                                       unpacks a driver package (mesa-vulkan-drivers_*.deb)
#                                       into DIR without installing it and writes DIR/icd.json
#                                       naming its lavapipe, for `drivers` (BENCHMARKS.md,
#                                       "A newer lavapipe").
source "$(dirname "$0")/common.sh"
cd "$ROOT"
RAYCAST=build/raycast
export CORPUS="${RAYCAST_CORPUS:-../shared/corpus/cs1230}"
# The usual place written as the file writes it: an absolute RAYCAST_CORPUS
# that is ../shared/corpus/cs1230 would otherwise put this machine's paths
# into every command line of the file (and into its diff).
if [ "$CORPUS" != ../shared/corpus/cs1230 ] && [ -d ../shared/corpus/cs1230 ] && [ -d "$CORPUS" ] \
  && [ "$(cd "$CORPUS" && pwd -P)" = "$(cd ../shared/corpus/cs1230 && pwd -P)" ]; then
  CORPUS=../shared/corpus/cs1230
fi

machine() {
  local commit
  commit="$(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
  if [ "$commit" != unknown ] && [ -n "$(git status --porcelain --untracked-files=no 2>/dev/null)" ]; then
    commit="$commit (with uncommitted changes)"
  fi
  # A copy of the tree without its history (a GPU machine's) says which commit it is.
  commit="${RAYCAST_COMMIT:-$commit}"
  echo "\`ci/benchmarks.sh machine\`, $(date -u '+%Y-%m-%d %H:%M UTC'), commit $commit:"
  echo
  # raycast's own words for the CPU (cpu::host_cpu: family, model, vector width, caches).
  echo "- CPU: $("$RAYCAST" devices 2>/dev/null | sed -n 's/^cpu: .* threads on //p'), \`nproc\` $(nproc)"
  echo "- memory: $(awk '/MemTotal/ { printf "%.1f GiB", $2 / 1048576 }' /proc/meminfo); kernel $(uname -r)"
  # Every device the loader shows (a lent GPU's run may carry lavapipe beside it for a window).
  echo "- Vulkan devices: $("$RAYCAST" devices | grep -E '^[0-9]+: ' | paste -sd ';' | sed 's/;/; /g')"
  echo "- mesa-vulkan-drivers $(dpkg-query -W -f '${Version}' mesa-vulkan-drivers 2>/dev/null || echo '(not a Debian package)'); $(rustc --version 2>/dev/null || echo 'rustc unknown')"
  echo "- load average when the run began (other work on the machine slows every number): $(cut -d' ' -f1-3 /proc/loadavg)"
}

# The median of a list of numbers separated by spaces.
# -v where binary $1 takes it (its render then prints the time and kernel
# lines); nothing for a build from before it, which printed them anyway.
verbose_flag() {
  if "$1" -v devices >/dev/null 2>&1; then echo -v; fi
}

median_of() {
  tr ' ' '\n' <<<"$1" | grep . | sort -g | awk '{ a[NR] = $1 } END { print (NR % 2 ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2) }'
}

# The scene file of SCENE (a file, or gen:FAMILY:DEPTH written into folder TMP by `raycast gen`).
# The scene's primitive count, expanded (`raycast info`: "primitives: 4,687 drawn").
primitive_count() {
  "$RAYCAST" info "$1" --assets "$CORPUS" 2>/dev/null | sed -n 's/^  primitives: \([0-9,]*\) drawn.*/\1/p' | tr -d ,
}

scene_file() {
  local s="$1" tmp="$2" family depth
  if [[ "$s" == gen:* ]]; then
    IFS=: read -r _ family depth <<<"$s"
    "$RAYCAST" gen "$family" --depth "$depth" -o "$tmp/$family-$depth.xml" >/dev/null 2>&1
    echo "$tmp/$family-$depth.xml"
  else
    echo "$s"
  fi
}

wall() {
  local max=() tmp
  while [ "${1:-}" = --max-primitives ] || [ "${1:-}" = --device ]; do max+=("$1" "$2"); shift 2; done
  tmp="$(mktemp -d)"
  echo "\`ci/benchmarks.sh wall ${max[*]}${max:+ }$*\`: \`$RAYCAST render SCENE --assets $CORPUS${max:+ }${max[*]}\` (512x384, shadows, reflections and textures on), run 3 times; the median wall time and the largest peak RSS (\`/usr/bin/time\`)."
  echo
  echo "| scene | primitives | wall time (median of 3) | peak RSS |"
  echo "|---|---|---|---|"
  local s file walls rss out n t m
  for s in "$@"; do
    file="$(scene_file "$s" "$tmp")"
    walls=() rss=0 n=""
    for _ in 1 2 3; do
      if ! out="$(/usr/bin/time -f 'TIME %e %M' "$RAYCAST" render "$file" --assets "$CORPUS" "${max[@]}" -o "$tmp/out.png" 2>&1)"; then
        if grep -q 'more than the limit' <<<"$out"; then
          n="skipped"
          break
        fi
        echo "$out" >&2
        exit 1
      fi
      read -r _ t m <<<"$(grep '^TIME' <<<"$out")"
      walls+=("$t")
      if [ "$m" -gt "$rss" ]; then rss="$m"; fi
      n="$(primitive_count "$file")"
    done
    if [ "$n" = skipped ]; then
      echo "| ${s##*/} | – | skipped: over the --max-primitives limit | – |"
    else
      n="$(sed ':a; s/\B[0-9]\{3\}\>/,&/; ta' <<<"$n")"
      echo "| ${s##*/} | $n | $(printf '%s\n' "${walls[@]}" | sort -n | sed -n 2p) s | $((rss / 1024)) MiB |"
    fi
  done
  rm -rf "$tmp"
}

# `raycast explain` per scene: a picture drawn with a copy of the shaders
# whose specular term is left out (--shaders, the device), then explain's
# wall time over 3 runs (median) and its first finding.
explain_times() {
  local tmp s file walls out t m first
  tmp="$(mktemp -d)"
  cp -r "$ROOT/shaders" "$tmp/shaders"
  sed -i 's/term = term + s.specular \* highlight;/term = term;/' "$tmp/shaders/lighting.glsl"
  # A 512x384 picture to draw like: the course's settings for each scene, as explain takes them.
  "$RAYCAST" render -q --backend cpu -o "$tmp/like.png"
  echo "\`ci/benchmarks.sh explain $*\`: \`$RAYCAST explain SCENE MINE.png --assets $CORPUS\` at 512x384, MINE.png drawn with the specular term left out of a copy of the shaders (\`render --shaders\`), run 3 times; the median wall time and the first finding."
  echo
  echo "| scene | wall time (median of 3) | peak RSS | first finding |"
  echo "|---|---|---|---|"
  for s in "$@"; do
    file="$(scene_file "$s" "$tmp")"
    "$RAYCAST" render -q --shaders "$tmp/shaders" --like "$tmp/like.png" "$file" --assets "$CORPUS" -o "$tmp/mine.png"
    walls=() m=0
    for _ in 1 2 3; do
      out="$(/usr/bin/time -f 'TIME %e %M' "$RAYCAST" explain "$file" "$tmp/mine.png" --assets "$CORPUS" 2>&1 || true)"
      read -r _ t rss <<<"$(grep '^TIME' <<<"$out")"
      walls+=("$t")
      if [ "$rss" -gt "$m" ]; then m="$rss"; fi
    done
    first="$(grep -m1 '^1\. ' <<<"$out" | sed 's/^1\. //; s/ (.*//')"
    echo "| ${s##*/} | $(printf '%s\n' "${walls[@]}" | sort -n | sed -n 2p) s | $((m / 1024)) MiB | ${first:-no finding} |"
  done
  rm -rf "$tmp"
}

# raycast and POV-Ray 3.7, the peer issue 7 names, on the same scenes in turn
# on this machine: raycast's whole command on the Vulkan device and with
# --backend cpu, then POV-Ray on the scene `raycast pov` writes (2 threads,
# its bounding hierarchy, every instance expanded), N rounds.
povray_side() {
  local rounds=5 tmp s file n v out t m i said povray_cmd=()
  if [ "${1:-}" = --rounds ]; then rounds="$2"; shift 2; fi
  command -v povray >/dev/null || { echo "benchmarks: povray is not installed (ci/install-deps.sh installs it)" >&2; exit 1; }
  tmp="$(mktemp -d)"
  # POV-Ray's command line as `raycast pov` gives it (render it with: …), run in $tmp.
  said="$("$RAYCAST" pov -o "$tmp/scene.pov" 2>&1 >/dev/null | sed -n 's/.*render it with: //p')"
  read -r -a povray_cmd <<<"${said//$tmp\//}"
  echo "\`ci/benchmarks.sh povray --rounds $rounds $*\`: in turn, $rounds round$([ "$rounds" = 1 ] || echo s): \`$RAYCAST render SCENE --assets $CORPUS\` (the Vulkan device), the same with \`--backend cpu\`, and \`${povray_cmd[*]}\` on the scene \`$RAYCAST pov SCENE --assets $CORPUS -o scene.pov\` writes (512x384, shadows, 4 mirror bounces, textures; POV-Ray expands every instance as it parses); the median wall time of each (\`/usr/bin/time\`) and the largest peak RSS."
  echo
  echo "| scene | primitives | raycast, device | raycast, \`--backend cpu\` | POV-Ray 3.7 | POV-Ray ÷ raycast, device | POV-Ray ÷ raycast, cpu | peak RSS: device, cpu, POV-Ray |"
  echo "|---|---|---|---|---|---|---|---|"
  for s in "$@"; do
    file="$(scene_file "$s" "$tmp")"
    "$RAYCAST" pov "$file" --assets "$CORPUS" -o "$tmp/scene.pov" 2>/dev/null || { "$RAYCAST" pov "$file" --assets "$CORPUS" -o "$tmp/scene.pov"; exit 1; }
    local -A walls=() rss=()
    local -A runs=([device]="" [cpu]="--backend cpu")
    for ((i = 0; i < rounds; i++)); do
      for v in device cpu povray; do
        if [ $v = povray ]; then
          out="$(cd "$tmp" && { /usr/bin/time -f 'TIME %e %M' "${povray_cmd[@]}"; } 2>&1)" || { echo "$out" >&2; exit 1; }
        else
          # shellcheck disable=SC2086 # the backend option, two words or none
          out="$( { /usr/bin/time -f 'TIME %e %M' "$RAYCAST" render "$file" --assets "$CORPUS" ${runs[$v]} -o "$tmp/out.png"; } 2>&1)" || { echo "$out" >&2; exit 1; }
        fi
        [ $v != device ] || n="$(primitive_count "$file")"
        read -r _ t m <<<"$(grep '^TIME' <<<"$out" | tail -1)"
        walls[$v]+="$t "
        if [ "$m" -gt "${rss[$v]:-0}" ]; then rss[$v]="$m"; fi
      done
    done
    local med=()
    for v in device cpu povray; do
      med+=("$(median_of "${walls[$v]}")")
    done
    echo "| ${s##*/} | $(sed ':a; s/\B[0-9]\{3\}\>/,&/; ta' <<<"$n") | ${med[0]} s | ${med[1]} s | ${med[2]} s | $(awk -v a="${med[0]}" -v b="${med[2]}" 'BEGIN { printf "%.1f", b / a }') | $(awk -v a="${med[1]}" -v b="${med[2]}" 'BEGIN { printf "%.1f", b / a }') | $((rss[device] / 1024)), $((rss[cpu] / 1024)), $((rss[povray] / 1024)) MiB |"
    unset walls rss runs
  done
  rm -rf "$tmp"
}

# Mitsuba 3 (pip's `mitsuba`, variant scalar_rgb), issue 45's second peer,
# beside raycast's CPU build on the same scenes in one run: the warm frames
# each side (raycast's `bench`, ci/mitsuba_bench.py's mi.render) and the
# whole commands, in turn, N rounds.
mitsuba_python() {
  if [ -n "${MITSUBA_PYTHON:-}" ]; then echo "$MITSUBA_PYTHON"; return; fi
  if ! build/mitsuba-venv/bin/python -c 'import mitsuba' 2>/dev/null; then
    echo "benchmarks: making build/mitsuba-venv (python3 -m venv, pip install mitsuba)" >&2
    python3 -m venv build/mitsuba-venv >&2 && build/mitsuba-venv/bin/pip install -q mitsuba >&2 \
      || { echo "benchmarks: cannot install mitsuba into build/mitsuba-venv (set MITSUBA_PYTHON to a python with it)" >&2; exit 1; }
  fi
  echo build/mitsuba-venv/bin/python
}

mitsuba_side() {
  local rounds=5 tmp s file n i py threads version json out t m counts
  if [ "${1:-}" = --rounds ]; then rounds="$2"; shift 2; fi
  py="$(mitsuba_python)"
  threads="$(nproc)"
  version="$("$py" -c 'import mitsuba; print(mitsuba.__version__)')"
  tmp="$(mktemp -d)"
  local picture=(--no-reflections --no-textures)
  echo "\`ci/benchmarks.sh mitsuba --rounds $rounds $*\`: raycast's CPU build beside Mitsuba $version (\`pip install mitsuba\`, variant scalar_rgb) on the scene \`$RAYCAST mitsuba SCENE --assets $CORPUS -o scene.xml\` writes (nested masters split into one shape group of at most 4,096 primitives placed by instances; the \`direct\` integrator, one emitter sample a light, no BSDF samples), 512x384, 1 spp, shadows on, mirrors and textures off, $threads threads each side. Warm frame: the median of $rounds frames after 1 untimed, \`$RAYCAST bench SCENE --assets $CORPUS --backend cpu ${picture[*]} --frames $rounds --warmup 1\` and \`ci/mitsuba_bench.py --frames $rounds --threads $threads scene.xml\` (mi.render). Rays a pixel: raycast's bench counts its camera and shadow rays (a shadow ray only where the light is in front of the surface); Mitsuba's are 1 + emitter samples x the camera rays' hits (an aov render counts them). Whole command, $rounds rounds in turn: \`$RAYCAST render SCENE --assets $CORPUS --backend cpu ${picture[*]}\` and \`ci/mitsuba_bench.py --frames 0 --threads $threads --png out.png scene.xml\` (Python's start, the import, the load, one frame, the PNG); the median wall time (\`/usr/bin/time\`)."
  echo
  echo "| scene | primitives | Mitsuba's scene: shapes, shape groups, instances | raycast cpu, warm frame | rays a pixel | Mitsuba, warm frame | rays a pixel | Mitsuba ÷ raycast, frame | Mitsuba ÷ raycast, a ray | raycast cpu, whole command | Mitsuba, whole command | Mitsuba ÷ raycast, whole |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
  for s in "$@"; do
    file="$(scene_file "$s" "$tmp")"
    out="$("$RAYCAST" mitsuba "$file" --assets "$CORPUS" -o "$tmp/scene.xml" 2>&1)" || { echo "$out" >&2; exit 1; }
    counts="$(sed -n 's/.*bytes: \([0-9]*\) shapes, \([0-9]*\) shape groups, \([0-9]*\) instances.*/\1, \2, \3/p' <<<"$out")"
    json="$("$RAYCAST" bench "$file" --assets "$CORPUS" --backend cpu "${picture[@]}" --frames "$rounds" --warmup 1 --json 2>/dev/null)" \
      || { "$RAYCAST" bench "$file" --assets "$CORPUS" --backend cpu "${picture[@]}" --frames 1 --warmup 0 >&2; exit 1; }
    local rc_frame rc_rays mi_frame mi_rays
    n="$(sed -n 's/.*"primitives_expanded":\([0-9]*\).*/\1/p' <<<"$json")"
    rc_frame="$(sed -n 's/.*"frame_ms_median":\([0-9.]*\).*/\1/p' <<<"$json")"
    rc_rays="$(awk -v r="$(sed -n 's/.*"all_rays_per_frame":\([0-9]*\).*/\1/p' <<<"$json")" 'BEGIN { printf "%.3f", r / (512 * 384) }')"
    out="$("$py" ci/mitsuba_bench.py --frames "$rounds" --threads "$threads" "$tmp/scene.xml" 2>&1)" || { echo "$out" >&2; exit 1; }
    mi_frame="$(sed -n 's/^mitsuba: frame median \([0-9.]*\) s.*/\1/p' <<<"$out")"
    mi_rays="$(sed -n 's/.*rays per pixel \([0-9.]*\).*/\1/p' <<<"$out")"
    local -A walls=()
    for ((i = 0; i < rounds; i++)); do
      out="$( { /usr/bin/time -f 'TIME %e %M' "$RAYCAST" render "$file" --assets "$CORPUS" --backend cpu "${picture[@]}" -o "$tmp/out.png"; } 2>&1)" || { echo "$out" >&2; exit 1; }
      read -r _ t m <<<"$(grep '^TIME' <<<"$out" | tail -1)"
      walls[raycast]+="$t "
      out="$( { /usr/bin/time -f 'TIME %e %M' "$py" ci/mitsuba_bench.py --frames 0 --threads "$threads" --png "$tmp/out-mitsuba.png" "$tmp/scene.xml"; } 2>&1)" || { echo "$out" >&2; exit 1; }
      read -r _ t m <<<"$(grep '^TIME' <<<"$out" | tail -1)"
      walls[mitsuba]+="$t "
    done
    local rc_wall mi_wall
    rc_wall="$(median_of "${walls[raycast]}")"
    mi_wall="$(median_of "${walls[mitsuba]}")"
    echo "| ${s##*/} | $(sed ':a; s/\B[0-9]\{3\}\>/,&/; ta' <<<"$n") | $counts | $(awk -v f="$rc_frame" 'BEGIN { printf "%.3f", f / 1000 }') s | $rc_rays | $mi_frame s | $mi_rays | $(awk -v a="$rc_frame" -v b="$mi_frame" 'BEGIN { printf "%.2f", b * 1000 / a }') | $(awk -v a="$rc_frame" -v b="$mi_frame" -v ra="$rc_rays" -v rb="$mi_rays" 'BEGIN { printf "%.2f", (b * 1000 / rb) / (a / ra) }') | $rc_wall s | $mi_wall s | $(awk -v a="$rc_wall" -v b="$mi_wall" 'BEGIN { printf "%.1f", b / a }') |"
    unset walls
  done
  rm -rf "$tmp"
}

preview_rates() {
  local opts=() tmp s file out line lines kind=moving scripted=(--frames 12 --moving 11) rest=""
  if [ "${1:-}" = --at-rest ]; then kind="at rest"; scripted=(--frames 12); rest="--at-rest "; shift; fi
  # Options with a value as --name=value (--backend=cpu).
  while [[ "${1:-}" == --* ]]; do opts+=("$1"); shift; done
  tmp="$(mktemp -d)"
  local what="the camera turns 2 degrees before each of frames 1 to 11, which render at the size the preview picks while you steer; the median of frames 2 to 11" size="frame size while steering"
  if [ "$kind" != moving ]; then
    what="every frame a whole sample at 512x384, as at rest; the median of frames 1 to 11 (the 12th is not timed)" size="frame size"
  fi
  echo "\`ci/benchmarks.sh preview $rest${opts[*]}${opts:+ }$*\`: \`xvfb-run -a $RAYCAST preview SCENE --assets $CORPUS${opts:+ }${opts[*]} ${scripted[*]}\` (a 512x384 window), 3 runs: $what, of the run with the middle median."
  echo
  echo "| scene | $size | median frame | frames a second |"
  echo "|---|---|---|---|"
  for s in "$@"; do
    file="$(scene_file "$s" "$tmp")"
    # Three runs; the one with the middle median (this machine's noise).
    lines=()
    for _ in 1 2 3; do
      out="$(xvfb-run -a -s '-screen 0 1280x1024x24' "$RAYCAST" preview "$file" --assets "$CORPUS" "${opts[@]}" "${scripted[@]}" 2>&1)" || { echo "$out" >&2; exit 1; }
      lines+=("$(grep "^$kind: " <<<"$out")")
    done
    line="$(printf '%s\n' "${lines[@]}" | awk '{ m = $0; sub(/.*median /, "", m); sub(/ ms.*/, "", m); print m "\t" $0 }' | sort -g | sed -n 2p | cut -f2-)"
    sed -n 's/^'"$kind"': [0-9]* frames\{0,1\} at \([0-9x][0-9x then]*[0-9]\)[^:]*: median \(.*\) a frame, \(.*\) frames a second$/| '"${s##*/}"' | \1 | \2 | \3 |/p' <<<"$line"
  done
  rm -rf "$tmp"
}

passes() {
  local tmp s out n first ratio aov=cost what="each camera ray's walk" all=""
  if [ "${1:-}" = --all ]; then aov=cost-all what="all the rays of each pixel (camera, shadow and mirror rays, traced as in colour), their walks summed" all="--all "; shift; fi
  tmp="$(mktemp -d)"
  echo "\`ci/benchmarks.sh passes $all$*\`: \`$RAYCAST render SCENE --assets $CORPUS --aov $aov --backend cpu\` (512x384, one sample a pixel): the passes of $what (a pass: an inner node's two boxes, an instance entered, or a leaf's tests; docs/cli.md, \"Views\"), the same counts on any device."
  echo
  echo "| scene | primitives N | ln N / ln N0 | mean passes | mean / first | median | 90% at most | 99% at most | most |"
  echo "|---|---|---|---|---|---|---|---|---|"
  first="" n0=""
  for s in "$@"; do
    # render takes gen:FAMILY:DEPTH names itself.
    out="$("$RAYCAST" render -v "$s" --assets "$CORPUS" --aov "$aov" --backend cpu -o "$tmp/cost.png" 2>&1)" || { echo "$out" >&2; exit 1; }
    n="$(sed -n 's/^scene: .* (\([0-9]*\) primitives.*/\1/p' <<<"$out")"
    read -r mean median p90 p99 most <<<"$(sed -n 's/^cost: .* \([0-9.]*\) passes on average: median \([0-9]*\), 90% at most \([0-9]*\), 99% at most \([0-9]*\), most \([0-9]*\).*/\1 \2 \3 \4 \5/p' <<<"$out")"
    [ -n "$first" ] || { first="$mean"; n0="$n"; }
    ratio="$(awk -v n="$n" -v n0="$n0" 'BEGIN { printf "%.2f", log(n) / log(n0) }')"
    echo "| ${s##*/} | $(sed ':a; s/\B[0-9]\{3\}\>/,&/; ta' <<<"$n") | $ratio | $mean | $(awk -v m="$mean" -v f="$first" 'BEGIN { printf "%.2f", m / f }') | $median | $p90 | $p99 | $most |"
  done
  rm -rf "$tmp"
}

checks() {
  local dev=() tmp s out any b n cells worst
  if [ "${1:-}" = --device ]; then dev=(--device "$2"); shift 2; fi
  tmp="$(mktemp -d)"
  echo "\`ci/benchmarks.sh checks ${dev[*]}${dev:+ }SCENE...\`: \`$RAYCAST check SCENE --assets $CORPUS${dev:+ }${dev[*]}\` (512x384, every setting at its default): pixels of 196,608 that differ between the device and the CPU build, per buffer; rgba with its worst channel difference."
  echo
  echo "| scene | any buffer | t | id | normal | rgba (worst) | rays |"
  echo "|---|---|---|---|---|---|---|"
  for s in "$@"; do
    out="$("$RAYCAST" check "$s" --assets "$CORPUS" "${dev[@]}" -o "$tmp/diff.png" 2>&1)" || true
    if grep -q '^identical' <<<"$out"; then
      any=0
    else
      any="$(sed -n 's/^\([0-9]*\) of [0-9]* pixels differ in at least one buffer.*/\1/p' <<<"$out")"
    fi
    if [ -z "$any" ]; then
      echo "| ${s#"$CORPUS"/} | error: $(grep -m1 'error' <<<"$out" | cut -c1-120) | | | | | |"
      continue
    fi
    cells=""
    for b in t id normal rgba rays; do
      n="$(sed -n "s/^$b: *\([0-9]*\) of .*/\1/p" <<<"$out")"
      if [ "$b" = rgba ] && [ "${n:-0}" != 0 ]; then
        worst="$(sed -n 's/^rgba:.*worst \([0-9]*\/255\).*/\1/p' <<<"$out")"
        n="$n ($worst)"
      fi
      cells="$cells | ${n:-?}"
    done
    echo "| ${s#"$CORPUS"/} | $any$cells |"
  done
  rm -rf "$tmp"
}

unpack_driver() {
  local deb="$1" dir="$2" icd lib
  [ -f "$deb" ] && [ -n "$dir" ] || { echo "usage: ci/benchmarks.sh unpack-driver DEB DIR" >&2; exit 2; }
  mkdir -p "$dir"
  dir="$(cd "$dir" && pwd)"
  dpkg-deb -x "$deb" "$dir/root"
  icd="$(ls "$dir"/root/usr/share/vulkan/icd.d/lvp_icd*.json 2>/dev/null | head -1)"
  lib="$(find "$dir/root" -name 'libvulkan_lvp.so' | head -1)"
  [ -n "$icd" ] && [ -n "$lib" ] || { echo "unpack-driver: $deb holds no lavapipe (lvp_icd*.json, libvulkan_lvp.so)" >&2; exit 1; }
  sed "s#\"library_path\": *\"[^\"]*\"#\"library_path\": \"$lib\"#" "$icd" >"$dir/icd.json"
  echo "$dir/icd.json: $(VK_DRIVER_FILES="$dir/icd.json" "$RAYCAST" devices | head -1)"
}

drivers() {
  local rounds=5 icd
  if [ "${1:-}" = --rounds ]; then rounds="$2"; shift 2; fi
  icd="$1"; shift
  [ -f "$icd" ] || { echo "drivers: no driver manifest $icd (ci/benchmarks.sh unpack-driver DEB DIR writes one)" >&2; exit 2; }
  echo "\`ci/benchmarks.sh drivers --rounds $rounds ICD.json $*\`: \`$RAYCAST render SCENE --assets $CORPUS\` (512x384, shadows, reflections and textures on) with A, the driver the loader finds, and B, \`VK_DRIVER_FILES=ICD.json\`, in turn, $rounds rounds after one untimed (each builds its kernels once; Mesa caches them): the medians of the whole command (its wall time to the ms, \`date +%s%N\` before and after) and of \`render\`'s compile and dispatch steps, and whether the two PNGs are the same bytes."
  echo
  echo "- A: $("$RAYCAST" devices | head -1 | sed 's/^[0-9]*: //')"
  echo "- B: $(VK_DRIVER_FILES="$icd" "$RAYCAST" devices | head -1 | sed 's/^[0-9]*: //')"
  echo
  ab_rows "$rounds" "" "VK_DRIVER_FILES=$icd" "$RAYCAST" "$RAYCAST" "$@"
}

settings() {
  local rounds=5 a b
  if [ "${1:-}" = --rounds ]; then rounds="$2"; shift 2; fi
  a="$1" b="$2"; shift 2
  echo "\`ci/benchmarks.sh settings --rounds $rounds '$a' '$b' $*\`: \`$RAYCAST render SCENE --assets $CORPUS\` (512x384, shadows, reflections and textures on) with A, \`$a\`, and B, \`$b\`, in the environment, in turn, $rounds rounds after one untimed: the medians of the whole command (its wall time to the ms, \`date +%s%N\` before and after) and of \`render\`'s compile and dispatch steps, and whether the two PNGs are the same bytes. Device: $("$RAYCAST" devices | head -1 | sed 's/^[0-9]*: //')."
  echo
  ab_rows "$rounds" "$a" "$b" "$RAYCAST" "$RAYCAST" "$@"
}

builds() {
  local rounds=5 a b
  if [ "${1:-}" = --rounds ]; then rounds="$2"; shift 2; fi
  a="$1" b="$2"; shift 2
  [ -x "$a" ] && [ -x "$b" ] || { echo "builds: OLD and NEW must be raycast binaries ($a, $b)" >&2; exit 2; }
  echo "\`ci/benchmarks.sh builds --rounds $rounds OLD NEW $*\`: \`render SCENE --assets $CORPUS\` (512x384, shadows, reflections and textures on) with A, OLD (\`$a\`), and B, NEW (\`$b\`), in turn, $rounds rounds after one untimed: the medians of the whole command (its wall time to the ms, \`date +%s%N\` before and after) and of \`render\`'s compile and dispatch steps, whether the two PNGs are the same bytes, and in how many rounds B's whole command was the shorter. Device: $("$b" devices | head -1 | sed 's/^[0-9]*: //')."
  echo
  ab_rows "$rounds" "" "" "$a" "$b" "$@"
}

# ROUNDS A_ENV B_ENV A_BIN B_BIN SCENE...: the table of `drivers`, `settings` and
# `builds`, `render` of each scene by A_BIN with A's VAR=VALUE words (space-separated)
# in its environment and by B_BIN with B's, in turn (`builds` adds each round's pair).
ab_rows() {
  local rounds="$1" a_env="$2" b_env="$3" a_bin="$4" b_bin="$5" s file tmp r v out t c d bin
  shift 5
  local pairs=false
  [ "$a_bin" = "$b_bin" ] || pairs=true
  tmp="$(mktemp -d)"
  if $pairs; then
    echo "| scene | whole, A | whole, B | compile, A | compile, B | dispatch, A | dispatch, B | B ÷ A, dispatch | same PNG | B's whole shorter |"
    echo "|---|---|---|---|---|---|---|---|---|---|"
  else
    echo "| scene | whole, A | whole, B | compile, A | compile, B | dispatch, A | dispatch, B | B ÷ A, dispatch | same PNG |"
    echo "|---|---|---|---|---|---|---|---|---|"
  fi
  for s in "$@"; do
    file="$(scene_file "$s" "$tmp")"
    local -A walls=() compiles=() dispatches=()
    local shorter=0
    for ((r = -1; r < rounds; r++)); do
      local a_wall=""
      for v in A B; do
        local env=()
        if [ $v = A ]; then read -r -a env <<<"$a_env"; bin="$a_bin"; else read -r -a env <<<"$b_env"; bin="$b_bin"; fi
        local t0 t1
        t0="$(date +%s%N)"
        # -v: the time and kernel lines (a build from before -v existed printed them without).
        out="$(env "${env[@]}" "$bin" render $(verbose_flag "$bin") "$file" --assets "$CORPUS" -o "$tmp/$v.png" 2>&1)" || { echo "$out" >&2; exit 1; }
        t1="$(date +%s%N)"
        [ "$r" -ge 0 ] || continue
        t="$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f", (b - a) / 1e9 }')"
        c="$(sed -n 's/^time: .*compile \([0-9.]*\) ms.*/\1/p' <<<"$out")"
        d="$(sed -n 's/^time: .*dispatch \([0-9.]*\) ms.*/\1/p' <<<"$out")"
        walls[$v]+="$t "
        compiles[$v]+="$c "
        dispatches[$v]+="$d "
        if [ $v = A ]; then a_wall="$t"; elif awk -v a="$a_wall" -v b="$t" 'BEGIN { exit !(b < a) }'; then shorter=$((shorter + 1)); fi
      done
    done
    local med=() list
    for list in "${walls[A]}" "${walls[B]}" "${compiles[A]}" "${compiles[B]}" "${dispatches[A]}" "${dispatches[B]}"; do
      med+=("$(median_of "$list")")
    done
    local same=no
    cmp -s "$tmp/A.png" "$tmp/B.png" && same=yes
    local row="| ${s##*/} | ${med[0]} s | ${med[1]} s | ${med[2]} ms | ${med[3]} ms | ${med[4]} ms | ${med[5]} ms | $(awk -v a="${med[4]}" -v b="${med[5]}" 'BEGIN { printf "%.2f", b / a }') | $same |"
    if $pairs; then row+=" $shorter of $rounds |"; fi
    echo "$row"
  done
  rm -rf "$tmp"
}

division() {
  local opts=() rounds=6 s v r out line kernel
  while [[ "${1:-}" == --* ]]; do
    if [ "$1" = --rounds ]; then rounds="$2"; else opts+=("$1" "$2"); fi
    shift 2
  done
  echo "\`ci/benchmarks.sh division ${opts[*]}${opts:+ }--rounds $rounds SCENE...\`: \`$RAYCAST render SCENE --assets $CORPUS${opts:+ }${opts[*]}\` under four settings in turn, $rounds rounds after one untimed: the exact kernel (\`--exact\`) with the GPU's division correction and the residuals the fma probe chose (by \`fma\` where the device's rounds once, docs/exactness.md, \"Division\"), with Dekker's residuals (\`RAYCAST_FMA_RESIDUALS=0\`), and without the correction (\`RAYCAST_INEXACT_DIVISION=0\`, which gives up the CPU build's bits); and the fast kernel (\`--kernel fast\`: the device's own division, square root and transcendentals, no \`precise\`; docs/exactness.md, \"The fast kernel\"); the median of \`render\`'s dispatch time, and each against the fast kernel's."
  echo
  echo "| scene | the probe's kernel | dispatch: the probe's | Dekker's | no correction | fast kernel | the probe's ÷ fast | Dekker's ÷ fast | none ÷ fast |"
  echo "|---|---|---|---|---|---|---|---|---|"
  for s in "$@"; do
    local -A times=()
    kernel=""
    # Round -1 is not timed: each kernel built once (Mesa and the drivers cache them).
    for ((r = -1; r < rounds; r++)); do
      for v in probe dekker none fast; do
        local setting=() which=(--exact)
        case $v in
          dekker) setting=(RAYCAST_FMA_RESIDUALS=0) ;;
          none) setting=(RAYCAST_INEXACT_DIVISION=0) ;;
          fast) which=(--kernel fast) ;;
        esac
        out="$(env "${setting[@]}" "$RAYCAST" render -v "$s" --assets "$CORPUS" "${which[@]}" "${opts[@]}" -o /dev/null 2>&1)" || { echo "$out" >&2; exit 1; }
        line="$(sed -n 's/^time: .*dispatch \([0-9.]*\) ms.*/\1/p' <<<"$out")"
        [ "$r" -lt 0 ] || times[$v]+="$line "
        if [ $v = probe ] && [ -z "$kernel" ]; then
          kernel="$(sed -n 's/^kernel: [a-z_]*\( with [A-Z_ a-z]*\),.*/\1/p' <<<"$out")"
          kernel="${kernel# with }"
        fi
      done
    done
    local median=() v2
    for v2 in probe dekker none fast; do
      median+=("$(median_of "${times[$v2]}")")
    done
    local ratio=() i
    for i in 0 1 2; do ratio+=("$(awk -v a="${median[$i]}" -v b="${median[3]}" 'BEGIN { printf "%.2f", a / b }')"); done
    echo "| ${s##*/} | ${kernel:-as given (no correction)} | ${median[0]} ms | ${median[1]} ms | ${median[2]} ms | ${median[3]} ms | ${ratio[0]} | ${ratio[1]} | ${ratio[2]} |"
  done
}


profile() {
  local opts=() frames=10 s size v line out
  while [[ "${1:-}" == --* ]]; do
    if [ "$1" = --frames ]; then frames="$2"; else opts+=("$1" "$2"); fi
    shift 2
  done
  echo "\`ci/benchmarks.sh profile ${opts[*]}${opts:+ }--frames $frames SCENE...\`: \`$RAYCAST bench SCENE --json --frames $frames --warmup 2 --assets $CORPUS${opts:+ }${opts[*]}\` at each size under five settings: all on with the exact kernel (\`--exact\`), all on with the fast kernel (\`--kernel fast\`), then on the fast kernel \`--no-shadows\`, \`--no-reflections\`, and both. frame: the whole render call (median); host dispatch: recording, submission and the wait; device: the queue's timestamps (clears of the buffers and the data images' copies; the dispatches; the output's copy for the host, none where the kernel writes host-visible memory); Mrays/s: every ray (camera, shadow, mirror) over the frame, and over the device's dispatch."
  echo
  echo "| scene | size | setting | frame | host dispatch | device clears | device dispatch | device readback copy | all Mrays/s (frame) | all Mrays/s (device dispatch) |"
  echo "|---|---|---|---|---|---|---|---|---|---|"
  for s in "$@"; do
    for size in ${PROFILE_SIZES:-1920x1080 512x384}; do
      for v in all fast no-shadows no-reflections neither; do
        local args=()
        case $v in
          all) args=(--exact) ;;
          fast) args=(--kernel fast) ;;
          no-shadows) args=(--kernel fast --no-shadows) ;;
          no-reflections) args=(--kernel fast --no-reflections) ;;
          neither) args=(--kernel fast --no-shadows --no-reflections) ;;
        esac
        out="$("$RAYCAST" bench "$s" --json --frames "$frames" --warmup 2 --assets "$CORPUS" \
          --width "${size%x*}" --height "${size#*x}" "${opts[@]}" "${args[@]}" 2>/dev/null)" || { echo "| ${s##*/} | $size | $v | failed |"; continue; }
        line="$(grep -m1 '"frame_ms_median"' <<<"$out")"
        if [ -z "$line" ]; then
          echo "| ${s##*/} | $size | $v | $(sed -n 's/.*"skipped":"\([^"]*\)".*/\1/p' <<<"$out" | head -1) |"
          continue
        fi
        local rays dd
        rays="$(json_field "$line" all_rays_per_frame)"
        dd="$(json_field "$line" device_dispatch_ms_median)"
        echo "| ${s##*/} | $size | $v | $(json_field "$line" frame_ms_median) ms | $(json_field "$line" dispatch_ms_median) ms | $(json_field "$line" device_clear_ms_median) ms | $dd ms | $(json_field "$line" device_readback_ms_median) ms | $(json_field "$line" all_mrays_per_s) | $(awk -v r="$rays" -v t="$dd" 'BEGIN { if (t > 0) printf "%.1f", r / t / 1e3; else print "–" }') |"
      done
    done
  done
  echo
  echo "Kernel statistics (\`$RAYCAST bench SCENE --kernel-stats --frames 1 --warmup 0 --width 1920 --height 1080${opts:+ }${opts[*]}\`), as the driver names them:"
  echo
  for s in "$@"; do
    echo "- ${s##*/}:"
    "$RAYCAST" bench "$s" --kernel-stats --frames 1 --warmup 0 --assets "$CORPUS" --width 1920 --height 1080 "${opts[@]}" 2>/dev/null \
      | sed -n '/kernel statistics/,$p' | grep -v 'cpu/gpu' | sed 's/^ */  - /'
  done
}

case "${1:-}" in
  machine) machine; exit ;;
  profile) shift; profile "$@"; exit ;;
  division) shift; division "$@"; exit ;;
  wall) shift; wall "$@"; exit ;;
  checks) shift; checks "$@"; exit ;;
  drivers) shift; drivers "$@"; exit ;;
  settings) shift; settings "$@"; exit ;;
  builds) shift; builds "$@"; exit ;;
  unpack-driver) shift; unpack_driver "$@"; exit ;;
  passes) shift; passes "$@"; exit ;;
  explain) shift; explain_times "$@"; exit ;;
  preview) shift; preview_rates "$@"; exit ;;
  povray) shift; povray_side "$@"; exit ;;
  mitsuba) shift; mitsuba_side "$@"; exit ;;
  peers) shift; povray_side "$@"; echo; mitsuba_side "$@"; exit ;;
esac

build=1 only="" skip=""
if [ "${1:-}" = --no-build ]; then build=0; shift; fi
if [ "${1:-}" = --only ]; then only="$2"; shift 2; fi
if [ "${1:-}" = --skip ]; then skip="$2"; shift 2; fi
FILE="${1:-BENCHMARKS.md}"
[ "$build" = 1 ] && build_raycast
[ -x "$RAYCAST" ] || { echo "benchmarks: $RAYCAST is missing: run without --no-build" >&2; exit 1; }
[ -d "$CORPUS/test_efficiency" ] || { echo "benchmarks: no corpus at $CORPUS: set RAYCAST_CORPUS" >&2; exit 1; }

out="$(mktemp)"
in_block=0 failed=0
while IFS= read -r line || [ -n "$line" ]; do
  if [ "$in_block" = 0 ] && [[ "$line" =~ ^'<!-- bench: '(.*)' -->'$ ]]; then
    printf '%s\n' "$line" >>"$out"
    if [[ "${BASH_REMATCH[1]}" == *'$LAVAPIPE_ICD'* ]] && [ ! -f "${LAVAPIPE_ICD:-}" ]; then
      # The second driver is not on every machine: its block stays as it is.
      echo "benchmarks: kept as it is (LAVAPIPE_ICD names no driver manifest; ci/benchmarks.sh unpack-driver DEB DIR writes one): ${BASH_REMATCH[1]}" >&2
      in_block=2
    elif [[ "${BASH_REMATCH[1]}" == *"$only"* ]] && { [ -z "$skip" ] || [[ "${BASH_REMATCH[1]}" != *"$skip"* ]]; }; then
      echo "benchmarks: ${BASH_REMATCH[1]}" >&2
      # One failing block costs only itself: it stays as it is, the blocks
      # before it keep their new results, and the run says so. (Not an
      # `if` on the subshell: that would turn off -e inside it, and a
      # block's first failing command would no longer fail the block.)
      block="$(mktemp)"
      set +e
      (set -e; eval "${BASH_REMATCH[1]}") >"$block" </dev/null
      status=$?
      set -e
      if [ "$status" = 0 ]; then
        cat "$block" >>"$out"
        in_block=1
      else
        echo "benchmarks: FAILED (exit $status), kept as it is: ${BASH_REMATCH[1]}" >&2
        failed=$((failed + 1))
        in_block=2
      fi
      rm -f "$block"
    else
      in_block=2 # kept as it is
    fi
  elif [ "$in_block" != 0 ]; then
    if [ "$line" = '<!-- /bench -->' ]; then
      printf '%s\n' "$line" >>"$out"
      in_block=0
    elif [ "$in_block" = 2 ]; then
      printf '%s\n' "$line" >>"$out"
    fi
  else
    printf '%s\n' "$line" >>"$out"
  fi
done <"$FILE"
[ "$in_block" = 0 ] || { echo "benchmarks: $FILE: a block is not closed with <!-- /bench -->" >&2; exit 1; }
mv "$out" "$FILE"
echo "benchmarks: wrote $FILE" >&2
[ "$failed" = 0 ] || { echo "benchmarks: $failed block(s) failed and were kept as they were" >&2; exit 1; }
