#!/usr/bin/env bash
# Installs the Debian 12 packages raycast needs to build, render and test.
# Idempotent: only missing packages are installed. Needs root (or sudo).
#
# RAYCAST_LAVAPIPE=backports takes Mesa (lavapipe and the rest of Mesa with
# it) from Debian's bookworm-backports, 25.0 where Debian 12 has 22.3: the
# same pictures, faster (BENCHMARKS.md, "A newer lavapipe"). It adds that
# archive to apt's sources (/etc/apt/sources.list.d/raycast-bookworm-backports.sources,
# unless one names it already), whose packages apt takes only when asked.
# Unset or `debian`: Debian 12's own, what CI tests on. Only on Debian 12
# (bookworm): Debian 13's own Mesa is 25.0 already, and bookworm's packages
# do not belong on any other release.
set -euo pipefail
lavapipe="${RAYCAST_LAVAPIPE:-debian}"
case "$lavapipe" in
  debian | backports) ;;
  *) echo "raycast: RAYCAST_LAVAPIPE=$lavapipe: expected debian or backports" >&2; exit 2 ;;
esac
codename="$( (. /etc/os-release 2>/dev/null && echo "${VERSION_CODENAME:-}") || true)"
if [ "$lavapipe" = backports ] && [ "$codename" != bookworm ]; then
  echo "raycast: RAYCAST_LAVAPIPE=backports is for Debian 12 (bookworm), not ${codename:-this system}: its own Mesa is used" >&2
  lavapipe=debian
fi

PKGS=(
  # build (make: the glfw crate builds its bundled GLFW with cmake's default generator, Unix Makefiles)
  cmake ninja-build g++ pkg-config make
  # Vulkan: loader + headers, Mesa lavapipe, validation layers, tools
  libvulkan-dev mesa-vulkan-drivers vulkan-validationlayers vulkan-tools
  # GLSL -> SPIR-V
  glslang-tools spirv-tools
  # CPU build of the shared GLSL
  libglm-dev libgtest-dev
  # GLFW 3.4 is built from the glfw crate's bundled sources; it needs these X11 headers
  libx11-dev libxrandr-dev libxinerama-dev libxcursor-dev libxi-dev libxkbcommon-dev
  # headless window tests (xdotool resizes a preview's window)
  xvfb xauth xdotool
  # the peer renderer: `raycast pov`'s scenes are drawn by it in the tests and timed beside raycast (BENCHMARKS.md)
  povray
)

missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done
# The backport is wanted and not there yet (its versions carry "~bpo12").
want_backport=0
if [ "$lavapipe" = backports ] && ! dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null | grep -q '~bpo12'; then
  want_backport=1
fi
if [ ${#missing[@]} -eq 0 ] && [ $want_backport = 0 ]; then
  exit 0
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null; then SUDO=sudo; else
    echo "raycast: need root to install: ${missing[*]}${missing:+ }$([ $want_backport = 1 ] && echo 'Mesa from bookworm-backports')" >&2; exit 1; fi
fi
export DEBIAN_FRONTEND=noninteractive
if [ $want_backport = 1 ] && ! grep -rqs 'bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d/; then
  echo "raycast: adding Debian's bookworm-backports to apt's sources (RAYCAST_LAVAPIPE=backports)" >&2
  printf 'Types: deb\nURIs: http://deb.debian.org/debian\nSuites: bookworm-backports\nComponents: main\nSigned-By: /usr/share/keyrings/debian-archive-keyring.gpg\n' |
    $SUDO tee /etc/apt/sources.list.d/raycast-bookworm-backports.sources >/dev/null
fi
$SUDO apt-get update -qq
if [ ${#missing[@]} -gt 0 ]; then
  echo "raycast: installing Debian packages: ${missing[*]}" >&2
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
fi
if [ $want_backport = 1 ]; then
  echo "raycast: installing Mesa's lavapipe from bookworm-backports (RAYCAST_LAVAPIPE=backports)" >&2
  $SUDO apt-get install -y -qq --no-install-recommends -t bookworm-backports mesa-vulkan-drivers >&2
  echo "raycast: mesa-vulkan-drivers $(dpkg-query -W -f='${Version}' mesa-vulkan-drivers)" >&2
fi
