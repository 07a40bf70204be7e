# Sourced by the ci/ scripts: finds the repository, cargo, and builds.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${RAYCAST_BUILD_DIR:-$ROOT/build}"

# rustup installs cargo under ~/.cargo/bin, which a non-login shell may miss.
for d in "${CARGO_HOME:-$HOME/.cargo}/bin" /usr/local/cargo/bin; do
  case ":$PATH:" in *":$d:"*) ;; *) [ -d "$d" ] && PATH="$d:$PATH" ;; esac
done
export PATH

# Installs missing Debian packages, configures and builds build/raycast.
build_raycast() {
  if ! command -v cargo >/dev/null 2>&1; then
    echo "raycast: cargo not found. raycast needs Rust 1.87 or newer (Debian 12's rustc 1.63 is too old):" >&2
    echo "         install it with rustup (https://rustup.rs) and run this again." >&2
    exit 1
  fi
  "$ROOT/ci/install-deps.sh"
  if [ ! -f "$BUILD/CMakeCache.txt" ]; then
    cmake -S "$ROOT" -B "$BUILD" -G Ninja >&2
  fi
  cmake --build "$BUILD" >&2
}
