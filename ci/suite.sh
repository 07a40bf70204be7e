#!/usr/bin/env bash
# How ctest runs a suite (CMakeLists.txt), so that one that leaves something
# out for want of the corpus, a Vulkan device or a display is counted as
# Skipped, never Passed:
#
#   ci/suite.sh NAME [--needs device] [--needs display] -- COMMAND...
#
# --needs device: the suite cannot run without a Vulkan device; where
#   `$RAYCAST_BIN devices` fails (no driver, no device) it is skipped, with
#   raycast's message, and does not run.
# --needs display: the suite runs windows under xvfb-run; where xvfb-run,
#   Xvfb or xauth is missing it is skipped and does not run.
# Otherwise COMMAND runs with RAYCAST_SKIP_FILE naming a fresh file, where
# the tests record each thing they skip (tests/common/mod.rs, `skip`: one
# line each). COMMAND failing fails the suite (its status); COMMAND passing
# with a line recorded, or COMMAND's own exit 77 (ci/lint.sh), is a skip:
# the reasons are printed and the exit is 77, ctest's SKIP_RETURN_CODE.
# Each skipped suite's reasons are also kept in $RAYCAST_SKIPS_DIR/NAME.txt,
# which ctest prints after its summary (`--report`, CTestCustom.cmake).
#
#   ci/suite.sh --report DIR
#
# prints the reasons kept in DIR, one suite after another.
set -uo pipefail

if [ "${1:-}" = --report ]; then
  dir="${2:?ci/suite.sh --report DIR}"
  shopt -s nullglob
  files=("$dir"/*.txt)
  [ ${#files[@]} = 0 ] && exit 0
  echo
  echo "Skipped, and why:"
  for f in "${files[@]}"; do
    while IFS= read -r line; do
      echo "  $(basename "$f" .txt): $line"
    done <"$f"
  done
  exit 0
fi

name="${1:?ci/suite.sh NAME [--needs device|display]... -- COMMAND...}"
shift
needs=()
while [ $# -gt 0 ] && [ "$1" != -- ]; do
  case "$1" in
    --needs) needs+=("${2:?--needs device|display}"); shift 2 ;;
    *) echo "ci/suite.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
[ "${1:-}" = -- ] && shift
[ $# -gt 0 ] || { echo "ci/suite.sh: no command after --" >&2; exit 2; }

kept="${RAYCAST_SKIPS_DIR:+$RAYCAST_SKIPS_DIR/$name.txt}"
[ -n "$kept" ] && rm -f "$kept"

# Prints the reasons ($1, one a line, each once), keeps them, exits 77.
skipped() {
  local reasons
  reasons="$(awk 'NF && !seen[$0]++' <<<"$1")"
  [ -n "$reasons" ] || reasons="(the command exited 77 without saying why: see its output above)"
  echo "$name: SKIPPED, so not counted as passed:"
  sed 's/^/  /' <<<"$reasons"
  if [ -n "$kept" ]; then
    mkdir -p "$RAYCAST_SKIPS_DIR"
    printf '%s\n' "$reasons" >"$kept"
  fi
  exit 77
}

for need in "${needs[@]}"; do
  case "$need" in
    device)
      bin="${RAYCAST_BIN:-}"
      if [ -z "$bin" ] || [ ! -x "$bin" ]; then
        echo "$name: cannot tell whether there is a Vulkan device (no raycast at '${bin}'); running the suite"
      elif ! msg="$(RAYCAST_VALIDATION=0 "$bin" devices 2>&1 >/dev/null)"; then
        skipped "no Vulkan device (\`raycast devices\` fails: $(tr '\n' ' ' <<<"$msg" | sed 's/ *$//')); the suite needs one and did not run"
      fi
      ;;
    display)
      missing=()
      for p in xvfb-run Xvfb xauth; do command -v "$p" >/dev/null 2>&1 || missing+=("$p"); done
      if [ ${#missing[@]} -gt 0 ]; then
        skipped "no display: ${missing[*]} not found (Debian packages xvfb and xauth); the suite runs its windows under xvfb-run and did not run"
      fi
      ;;
    *) echo "ci/suite.sh: unknown need $need (device, display)" >&2; exit 2 ;;
  esac
done

RAYCAST_SKIP_FILE="$(mktemp "${TMPDIR:-/tmp}/raycast-skips-$name.XXXXXX")"
export RAYCAST_SKIP_FILE
out="$(mktemp "${TMPDIR:-/tmp}/raycast-out-$name.XXXXXX")"
trap 'rm -f "$RAYCAST_SKIP_FILE" "$out"' EXIT

"$@" 2>&1 | tee "$out"
rc=${PIPESTATUS[0]}
if [ "$rc" = 77 ]; then
  # The command's own skip (ci/lint.sh): its lines that say SKIPPED.
  skipped "$(cat "$RAYCAST_SKIP_FILE"; grep -i 'skipped' "$out" | sed 's/^[[:space:]]*//')"
fi
[ "$rc" = 0 ] || exit "$rc"
[ -s "$RAYCAST_SKIP_FILE" ] && skipped "$(cat "$RAYCAST_SKIP_FILE")"
exit 0
