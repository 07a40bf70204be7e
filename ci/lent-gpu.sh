#!/usr/bin/env bash
# Packs what a lent GPU machine lacks into one folder, to run raycast there
# (docs/platforms.md#lent-gpu-machines):
#
#   ci/lent-gpu.sh checks|preview [DIR]          (DIR: .lent, which .gitignore leaves out)
#
# Those machines (the device tool of the development workplace) have the
# NVIDIA driver and nothing else this needs: no Vulkan loader, validation
# layer, GLSL compilers, GLM, Xvfb or second Vulkan device, and nothing can
# be downloaded there. Everything comes from this machine's Debian (apt-get
# download, with a private package list: the system's apt state is not
# touched) and build/, into DIR:
#   debs/       the Vulkan loader and GL dispatch (unpacked onto / there, where
#               the machine has no libvulkan.so.1)
#   extra/      the validation layer; with `checks` also glslang-tools,
#               spirv-tools, libglm-dev (the shader-test harness) and time
#               (`ci/benchmarks.sh wall`)
#   window.tar.xz  with `preview`: Debian's Xvfb, xkbcomp and xkb data, lavapipe
#               (a Vulkan device that can present to that Xvfb, where NVIDIA's
#               driver cannot) and their libraries, and a stand-in xvfb-run
#   corpus/     the corpus ($RAYCAST_CORPUS): all of it with `checks`, the
#               test_efficiency scenes and the texture they use with `preview`
#               (all of it would pass the call's 64 MiB beside the window)
#   raycast, shaders/   build/raycast stripped (7 MB where it is 42) and build/shaders
#   raycast-old where OLD_RAYCAST names an older binary: it stripped, for
#               ci/gpu-summary.sh --old build/raycast-old
#   check-suite with `checks`, where ci/test.sh built it: the check suite's binary
#               (tests/check.rs) stripped, for gpu-checks.sh's step of that name
#   run.sh      there: unpacks, sets PATH, LD_LIBRARY_PATH, VK_DRIVER_FILES,
#               VK_LAYER_PATH, RAYCAST_CORPUS and RAYCAST_COMMIT, puts raycast and
#               the shaders in build/, then runs its arguments
# Then, with the device tool: run `bash .lent/run.sh ci/gpu-checks.sh --device
# NVIDIA /tmp/logs`, carrying [".lent"]. The two kinds are apart because
# together they pass the 64 MiB a call may carry; the size is printed.
source "$(dirname "$0")/common.sh"
kind="${1:-}"
case "$kind" in checks | preview) ;; *)
  echo "usage: ci/lent-gpu.sh checks|preview [DIR]" >&2
  exit 2
  ;;
esac
dir="${2:-$ROOT/.lent}"
corpus="${RAYCAST_CORPUS:-$ROOT/../shared/corpus/cs1230}"
[ -x "$BUILD/raycast" ] || { echo "lent-gpu: $BUILD/raycast is missing: build first" >&2; exit 1; }
[ -d "$corpus/test_efficiency" ] || { echo "lent-gpu: no corpus at $corpus: set RAYCAST_CORPUS" >&2; exit 1; }
rm -rf "$dir"
mkdir -p "$dir/debs" "$dir/extra" "$dir/corpus"

# Debian's packages, as the device README fetches them.
apt_state="$(mktemp -d)"
trap 'rm -rf "$apt_state"' EXIT
mkdir -p "$apt_state/lists/partial"
apt_opts=(-o APT::Architecture=amd64 -o APT::Architectures=amd64 -o "Dir::State::Lists=$apt_state/lists")
apt-get "${apt_opts[@]}" update >/dev/null 2>&1 || { echo "lent-gpu: apt-get update failed" >&2; exit 1; }
fetch() { # FOLDER PACKAGE...
  (cd "$1" && shift && apt-get "${apt_opts[@]}" download "$@" >/dev/null 2>&1) ||
    { echo "lent-gpu: apt-get download $* failed" >&2; exit 1; }
}
fetch "$dir/debs" libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2
fetch "$dir/extra" vulkan-validationlayers
if [ "$kind" = checks ]; then
  fetch "$dir/extra" glslang-tools spirv-tools libglm-dev time
  cp -r "$corpus/." "$dir/corpus/"
else
  mkdir -p "$dir/corpus/image"
  cp -r "$corpus/test_efficiency" "$dir/corpus/"
  cp "$corpus/image/marsTexture.png" "$dir/corpus/image/"
fi

if [ "$kind" = preview ]; then
  lvp=/usr/lib/x86_64-linux-gnu/libvulkan_lvp.so
  for f in /usr/bin/Xvfb /usr/bin/xkbcomp "$lvp" /usr/share/X11/xkb /usr/share/vulkan/icd.d/lvp_icd.x86_64.json; do
    [ -e "$f" ] || { echo "lent-gpu: $f is missing here (ci/install-deps.sh installs it)" >&2; exit 1; }
  done
  w="$(mktemp -d)/window"
  mkdir -p "$w/bin" "$w/lib" "$w/icd"
  cp /usr/bin/Xvfb /usr/bin/xkbcomp "$w/bin/"
  cp "$lvp" "$w/lib/"
  cp -r /usr/share/X11/xkb "$w/xkb"
  # Their libraries, but glibc's and the C++ runtime's, which the machine has.
  ldd /usr/bin/Xvfb /usr/bin/xkbcomp "$lvp" | awk '/=>/ { print $3 }' | sort -u |
    grep -vE '/(libc|libm|libpthread|libdl|librt|libresolv|ld-linux-x86-64|libstdc\+\+|libgcc_s)\.so' |
    while read -r lib; do cp -L "$lib" "$w/lib/"; done
  sed 's#"library_path": *"[^"]*"#"library_path": "/tmp/window/lib/libvulkan_lvp.so"#' \
    /usr/share/vulkan/icd.d/lvp_icd.x86_64.json >"$w/icd/lvp.json"
  cat >"$w/bin/xvfb-run" <<'EOF'
#!/usr/bin/env bash
# A stand-in for Debian's xvfb-run (which needs xauth): xvfb-run [-a] [-s 'ARGS'] COMMAND...
args="-screen 0 1280x1024x24"
while [ $# -gt 0 ]; do
  case "$1" in -a) shift ;; -s) args="$2"; shift 2 ;; *) break ;; esac
done
fifo="$(mktemp -u)"; mkfifo "$fifo"
Xvfb -displayfd 3 -noreset -nolisten tcp $args 3>"$fifo" 2>/dev/null &
xvfb=$!
read -r -t 10 display <"$fifo"; rm -f "$fifo"
[ -n "$display" ] || { kill $xvfb 2>/dev/null; echo "xvfb-run: Xvfb did not start" >&2; exit 1; }
DISPLAY=":$display" "$@"; rc=$?
kill $xvfb 2>/dev/null; wait $xvfb 2>/dev/null
exit $rc
EOF
  chmod +x "$w/bin/xvfb-run"
  tar cJf "$dir/window.tar.xz" -C "$(dirname "$w")" window
  rm -rf "$(dirname "$w")"
fi

strip -o "$dir/raycast" "$BUILD/raycast"
# An older binary to measure beside this one (ci/gpu-summary.sh --old), where OLD_RAYCAST names one.
if [ -n "${OLD_RAYCAST:-}" ]; then strip -o "$dir/raycast-old" "$OLD_RAYCAST"; fi
cp -r "$BUILD/shaders" "$dir/shaders"
if [ "$kind" = checks ]; then
  # The newest build of tests/check.rs (cargo names it check-HASH).
  suite="$(ls -t "$BUILD"/cargo/release/deps/check-* 2>/dev/null | grep -v '\.d$' | head -n 1)"
  if [ -n "$suite" ]; then strip -o "$dir/check-suite" "$suite"
  else echo "lent-gpu: no check suite binary in $BUILD/cargo (ci/test.sh builds it): gpu-checks will skip that step"; fi
fi
commit="$(git -C "$ROOT" rev-parse --short HEAD)"
git -C "$ROOT" diff --quiet HEAD || commit="$commit with changes"
cat >"$dir/run.sh" <<EOF
#!/usr/bin/env bash
# Made by ci/lent-gpu.sh $kind at $commit: run from the repository root there.
set -u
here="\$(cd "\$(dirname "\$0")" && pwd)"
if ! ldconfig -p | grep -q 'libvulkan.so.1 '; then
  for f in "\$here"/debs/*.deb; do dpkg -x "\$f" /; done
  ldconfig
fi
mkdir -p /tmp/extra
for f in "\$here"/extra/*.deb; do [ -e "\$f" ] && dpkg -x "\$f" /tmp/extra; done
[ -x /usr/bin/time ] || [ ! -d /tmp/extra/usr/bin ] || cp /tmp/extra/usr/bin/time /usr/bin/time 2>/dev/null || true
drivers=""
for f in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json /usr/share/vulkan/icd.d/nvidia_icd.json; do
  [ -f "\$f" ] && { drivers="\$f"; break; }
done
export LD_LIBRARY_PATH=/tmp/extra/usr/lib/x86_64-linux-gnu\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}
export PATH=/tmp/extra/usr/bin:\$PATH CPLUS_INCLUDE_PATH=/tmp/extra/usr/include
if [ -f "\$here/window.tar.xz" ]; then
  tar xJf "\$here/window.tar.xz" -C /tmp
  [ -x /usr/bin/xkbcomp ] || cp /tmp/window/bin/xkbcomp /usr/bin/
  [ -d /usr/share/X11/xkb ] || { mkdir -p /usr/share/X11; cp -r /tmp/window/xkb /usr/share/X11/xkb; }
  export PATH=/tmp/window/bin:\$PATH LD_LIBRARY_PATH=/tmp/window/lib:\$LD_LIBRARY_PATH
  drivers="\$drivers\${drivers:+:}/tmp/window/icd/lvp.json"
fi
[ -z "\$drivers" ] || export VK_DRIVER_FILES="\$drivers"
export VK_LAYER_PATH=/tmp/extra/usr/share/vulkan/explicit_layer.d
export RAYCAST_CORPUS="\$here/corpus" RAYCAST_COMMIT="$commit"
mkdir -p build
cp "\$here/raycast" build/raycast
rm -rf build/shaders && cp -r "\$here/shaders" build/shaders
[ ! -f "\$here/check-suite" ] || cp "\$here/check-suite" build/check-suite
[ ! -f "\$here/raycast-old" ] || cp "\$here/raycast-old" build/raycast-old
"\$@"
EOF
chmod +x "$dir/run.sh"
bytes="$(du -sb "$dir" | cut -f1)"
echo "lent-gpu: $dir: $((bytes / 1048576)) MiB ($kind, commit $commit); the device tool carries 64 MiB a call with the tree"
[ "$bytes" -lt $((60 * 1048576)) ] || echo "lent-gpu: warning: with the working tree that may pass the 64 MiB limit" >&2
