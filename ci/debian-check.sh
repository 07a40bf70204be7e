#!/usr/bin/env bash
# Checks that raycast builds, renders and passes its whole suite on a fresh,
# minimal Debian (debootstrap's minbase: no make, no compiler, nothing the
# CI machine happens to have), with that release's own packages, in a chroot
# on this Debian machine: Debian 12 (bookworm), what the README promises, or
# Debian 13 (trixie: Mesa 25 with LLVM 19, glslang 15, GCC 14). Not part of
# CI (whose machine is not minimal); run it by hand after a change to the
# build, the installed packages, the shaders or the SPIR-V handling. It found
# glslang 15's write-only buffers, which naga refused (28fa9b7), and the
# missing `make` that the glfw crate's GLFW build needs (9d36a0f).
#
#   ci/debian-check.sh [bookworm|trixie] [DIR]    # default trixie; DIR: the chroot
#                                                 # (default /tmp/raycast-SUITE; reused when there)
#
# Needs root, debootstrap (installed from Debian when missing), deb.debian.org,
# and cargo from rustup (its ~/.cargo and ~/.rustup are bound into the chroot,
# so the same toolchain and the crates already fetched serve there). The
# clone is of this repository's HEAD (commit first); the corpus
# (RAYCAST_CORPUS, default ../shared/corpus/cs1230) is bound in for the
# conformance tests. Steps: the README's first command in the chroot, its PNG
# compared byte for byte with build/raycast's here (built first when
# missing), then the README's test command. Exit 0 when all three hold. The
# mounts are undone on exit; the chroot stays for the next run (about 400 MB).
set -euo pipefail
source "$(dirname "$0")/common.sh"
SUITE="${1:-trixie}"
case "$SUITE" in
  bookworm | trixie) ;;
  *) echo "raycast: ci/debian-check.sh $SUITE: expected bookworm (Debian 12) or trixie (Debian 13)" >&2; exit 2 ;;
esac
T="${2:-/tmp/raycast-$SUITE}"
CORPUS="${RAYCAST_CORPUS:-$ROOT/../shared/corpus/cs1230}"
CARGO_DIR="${CARGO_HOME:-$HOME/.cargo}"
RUSTUP_DIR="${RUSTUP_HOME:-$HOME/.rustup}"

if [ "$(id -u)" -ne 0 ]; then
  echo "raycast: ci/debian-check.sh needs root (debootstrap, chroot, mounts)" >&2
  exit 1
fi
for d in "$CARGO_DIR/bin" "$RUSTUP_DIR"; do
  [ -d "$d" ] || { echo "raycast: no $d: the check binds rustup's toolchain into the chroot" >&2; exit 1; }
done
[ -d "$CORPUS" ] || { echo "raycast: no corpus at $CORPUS (RAYCAST_CORPUS)" >&2; exit 1; }
CORPUS="$(cd "$CORPUS" && pwd)"

if ! command -v debootstrap >/dev/null; then
  apt-get install -y -qq debootstrap >&2
fi
if [ ! -x "$T/bin/bash" ]; then
  echo "raycast: making a minimal $SUITE chroot in $T" >&2
  debootstrap --variant=minbase --include=ca-certificates,git,python3 "$SUITE" "$T" http://deb.debian.org/debian >&2
fi
cp /etc/resolv.conf "$T/etc/resolv.conf"

mounted=()
bind() { # bind SOURCE TARGET-INSIDE
  mkdir -p "$T$2"
  mount --rbind "$1" "$T$2"
  mounted=("$T$2" "${mounted[@]}")
}
cleanup() {
  for m in "${mounted[@]}"; do umount -R "$m" 2>/dev/null || umount -lR "$m" 2>/dev/null || true; done
}
trap cleanup EXIT
mount -t proc proc "$T/proc" && mounted=("$T/proc")
bind /sys /sys
bind /dev /dev
bind "$CARGO_DIR" /root/.cargo
bind "$RUSTUP_DIR" /root/.rustup
bind "$CORPUS" /corpus

rm -rf "$T/raycast"
git clone -q "$ROOT" "$T/raycast"
echo "raycast: Debian $(cat "$T/etc/debian_version") chroot, commit $(git -C "$T/raycast" log --oneline -1)" >&2
in_chroot() {
  chroot "$T" env -i HOME=/root PATH=/root/.cargo/bin:/usr/sbin:/usr/bin:/sbin:/bin TERM=dumb bash -c "cd /raycast && $1"
}

in_chroot "ci/raycast.sh render -o default.png"
[ -x "$BUILD/raycast" ] || build_raycast
here="$(mktemp --suffix=.png)"
"$BUILD/raycast" render -o "$here" >/dev/null
if cmp -s "$here" "$T/raycast/default.png"; then
  echo "raycast: the default scene's PNG on Debian $(cat "$T/etc/debian_version") is byte for byte this machine's" >&2
  rm -f "$here"
else
  echo "raycast: the default scene's PNG differs: $SUITE's $T/raycast/default.png, this machine's $here" \
    "(raycast compare says where)" >&2
  exit 1
fi
in_chroot "RAYCAST_CORPUS=/corpus ci/test.sh"
echo "raycast: Debian $(cat "$T/etc/debian_version") ($SUITE): the README's two commands work (the PNG the same bytes, the suite passed)" >&2
