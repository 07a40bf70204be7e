#!/usr/bin/env bash
# Clippy over every target (the program, its tests, the build script), any
# warning an error: ctest's `lint` (CMakeLists.txt), after the build. Checks
# in its own target folder (`$CARGO_TARGET_DIR`, build/clippy from ctest), so
# the tests' release builds are not touched. Exit 77, which ctest counts as
# skipped and says so, where cargo has no clippy (rustup's minimal profile).
source "$(dirname "$0")/common.sh"
if ! cargo clippy --version >/dev/null 2>&1; then
  echo "lint: SKIPPED: cargo clippy is not installed (rustup component add clippy)"
  exit 77
fi
cargo clippy --version
exec cargo clippy --locked --all-targets --manifest-path "$ROOT/Cargo.toml" -- -D warnings
