# Sourced by the ci/ scripts: finds the repository, cargo, and builds.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${RAYCAST_BUILD_DIR:-$ROOT/build}"

# rustup installs cargo under ~/.cargo/bin, which a non-login shell may miss.
for d in "${CARGO_HOME:-$HOME/.cargo}/bin" /usr/local/cargo/bin; do
  case ":$PATH:" in *":$d:"*) ;; *) [ -d "$d" ] && PATH="$d:$PATH" ;; esac
done
export PATH

# RAYCAST_CORPUS made absolute, from the folder the script was started in,
# before anything changes folder: cargo runs the tests from host/ and ctest
# from the repository, where a relative path points elsewhere. Unset or
# empty, it stays so (what needs the corpus skips, and says so); set to
# something that is not a folder, this fails.
absolute_corpus() {
  [ -n "${RAYCAST_CORPUS:-}" ] || return 0
  if [ ! -d "$RAYCAST_CORPUS" ]; then
    echo "raycast: RAYCAST_CORPUS=$RAYCAST_CORPUS is not a folder (from $PWD); point it at the cs1230 corpus, e.g. ../shared/corpus/cs1230" >&2
    exit 1
  fi
  RAYCAST_CORPUS="$(cd "$RAYCAST_CORPUS" && pwd)"
  export RAYCAST_CORPUS
}

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

# A number field of one `bench --json` line ("null" where absent).
json_field() {
  sed -n "s/.*\"$2\":\([^,}]*\).*/\1/p" <<<"$1"
}
