#!/usr/bin/env bash
# The Rust code's lint: rustfmt's layout (rustfmt.toml) and clippy over every
# target (the program, its tests, the build script), any warning an error.
# ctest's `lint` (CMakeLists.txt), after the build. Clippy checks in its own
# target folder (`$CARGO_TARGET_DIR`, build/clippy from ctest), so the
# tests' release builds are not touched. Exit 77, which ctest counts as
# skipped and says so, where cargo lacks either tool (rustup's minimal
# profile): the one it has still runs first, and fails the test if it finds
# something.
source "$(dirname "$0")/common.sh"
have_fmt=0; have_clippy=0
cargo fmt --version >/dev/null 2>&1 && have_fmt=1
cargo clippy --version >/dev/null 2>&1 && have_clippy=1
if [ $have_fmt = 1 ]; then
  cargo fmt --version
  # --check prints each place as a diff; `cargo fmt` (from the repository root) fixes them.
  if ! cargo fmt --check --manifest-path "$ROOT/Cargo.toml"; then
    echo "lint: FAILED: the code above is not in rustfmt's layout; run \`cargo fmt\` in $ROOT" >&2
    exit 1
  fi
else
  echo "lint: rustfmt SKIPPED: cargo fmt is not installed (rustup component add rustfmt); clippy runs where it is, and the test counts as skipped"
fi
if [ $have_clippy = 0 ]; then
  echo "lint: SKIPPED (rustfmt passed): cargo clippy is not installed (rustup component add clippy)"
  exit 77
fi
cargo clippy --version
cargo clippy --locked --all-targets --manifest-path "$ROOT/Cargo.toml" -- -D warnings || exit 1
if [ $have_fmt = 0 ]; then
  echo "lint: SKIPPED (clippy passed): cargo fmt is not installed"
  exit 77
fi
