#!/usr/bin/env bash
# Installs the Debian 12 packages raycast needs to build, render and test.
# Idempotent: only missing packages are installed. Needs root (or sudo).
set -euo pipefail

PKGS=(
  # build
  cmake ninja-build g++ pkg-config
  # Vulkan: loader + headers, Mesa lavapipe, validation layers, tools
  libvulkan-dev mesa-vulkan-drivers vulkan-validationlayers vulkan-tools
  # GLSL -> SPIR-V
  glslang-tools spirv-tools
  # CPU build of the shared GLSL
  libglm-dev libgtest-dev
  # GLFW 3.4 is built from the glfw crate's bundled sources; it needs these X11 headers
  libx11-dev libxrandr-dev libxinerama-dev libxcursor-dev libxi-dev libxkbcommon-dev
  # headless window tests
  xvfb xauth
)

missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "raycast: installing Debian packages: ${missing[*]}" >&2
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null; then SUDO=sudo; else
    echo "raycast: need root to install: ${missing[*]}" >&2; exit 1; fi
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
