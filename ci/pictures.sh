#!/usr/bin/env bash
# The picture baseline: renders a fixed set of pictures and compares two such
# sets byte for byte, so that a refactor can show it changed no pixel.
#
#   ci/pictures.sh [REV]            render REV's set (default HEAD) and the
#                                   working tree's, compare them (exit 4 on
#                                   any difference)
#   ci/pictures.sh render BIN DIR   render the set with the raycast binary BIN
#   ci/pictures.sh build REV        build REV apart; print its binary's path
#   ci/pictures.sh compare A B      compare two sets byte for byte
#
# The set: every corpus scene, the repository's own scenes (tests/scenes but
# bad/), the default scene and the generated ones, on the device (lavapipe
# or whichever `--backend gpu` picks) and on the CPU build; in colour, in
# each view (normal, depth, id, cost, cost-all, samples), at --spp 4, with
# the course's supersampling and texture filter at 1024x768 (the four
# scenes the course rendered so), and without shadows, reflections and
# textures (the test_unit references). Each picture is named
# SET/GROUP/SCENE.png; SET names the backend and the settings. About 1,200
# pictures, 15 to 20 minutes on 2 cores.
#
# Needs RAYCAST_CORPUS (the cs1230 corpus): without it, the set would be a
# different set, so this refuses. REV is built in a worktree under
# build/pictures (kept, so later builds are incremental); sets go to
# build/pictures/sets/<commit> and build/pictures/sets/work.
source "$(dirname "$0")/common.sh"
absolute_corpus
PICS="$BUILD/pictures"

need_corpus() {
  if [ -z "${RAYCAST_CORPUS:-}" ]; then
    echo "pictures: set RAYCAST_CORPUS to the cs1230 corpus (e.g. ../shared/corpus/cs1230): the set renders every corpus scene" >&2
    exit 1
  fi
}

# build REV: a worktree at build/pictures/src checked out at REV, built into
# build/pictures/build. Prints the binary's path on stdout.
build_rev() {
  local rev commit src="$PICS/src"
  rev="$1"
  commit="$(git -C "$ROOT" rev-parse --verify "$rev^{commit}")"
  mkdir -p "$PICS"
  if [ ! -e "$src/.git" ]; then
    git -C "$ROOT" worktree prune
    git -C "$ROOT" worktree add --detach "$src" "$commit" >&2
  else
    git -C "$src" checkout --quiet --detach "$commit"
  fi
  if [ ! -f "$PICS/build/CMakeCache.txt" ]; then
    cmake -S "$src" -B "$PICS/build" -G Ninja >&2
  fi
  cmake --build "$PICS/build" >&2
  echo "$PICS/build/raycast"
}

# render BIN DIR: the whole set with BIN into DIR (emptied first).
render_set() {
  local bin="$1" out="$2"
  need_corpus
  rm -rf "$out"
  mkdir -p "$out"
  out="$(cd "$out" && pwd)"
  local -a groups=()
  local d
  # Scene groups: each corpus folder, each of the repository's own folders.
  for d in "$RAYCAST_CORPUS"/*/ "$ROOT"/tests/scenes/ "$ROOT"/tests/scenes/*/; do
    d="${d%/}"
    [ "$(basename "$d")" = bad ] && continue
    compgen -G "$d/*.xml" >/dev/null || continue
    groups+=("$d")
  done
  local -a gens=(gen:recursive-spheres:5 gen:recursive-cones:4 gen:recursive-cubes:4)

  # NAME|FLAGS|SCENES: every set is drawn on both backends; SCENES, where
  # given, is a pattern of the scene files' names that the set draws (the
  # course's 1024x768 renders are of four scenes, and slow on lavapipe).
  local -a sets=(
    "color||"
    "normal|--aov normal|"
    "depth|--aov depth|"
    "id|--aov id|"
    "cost|--aov cost|"
    "cost-all|--aov cost-all|"
    "samples|--aov samples --supersample course|"
    "spp4|--spp 4|"
    "course1024|--width 1024 --height 768 --supersample course --texture-filter course|@(dof|robot|refract|recursiveSpheres1).xml"
    "plain|--no-shadows --no-reflections --no-textures|"
  )
  shopt -s extglob
  local entry name flags only backend g group f failed=0
  for entry in "${sets[@]}"; do
    name="${entry%%|*}"
    flags="${entry#*|}"
    only="${flags#*|}"
    flags="${flags%%|*}"
    for backend in gpu cpu; do
      local dir="$out/$backend-$name"
      echo "pictures: $backend-$name" >&2
      for g in "${groups[@]}"; do
        group="$(basename "$g")"
        [ "$g" = "$ROOT/tests/scenes" ] && group=own
        local -a files=()
        for f in "$g"/*.xml; do
          # shellcheck disable=SC2053
          [ -z "$only" ] || [[ "$(basename "$f")" == $only ]] || continue
          files+=("$f")
        done
        [ ${#files[@]} = 0 ] && continue
        mkdir -p "$dir/$group"
        # shellcheck disable=SC2086
        "$bin" render -q --backend "$backend" $flags --assets "$RAYCAST_CORPUS" \
          --out-dir "$dir/$group" "${files[@]}" || failed=1
      done
      [ -n "$only" ] && continue
      mkdir -p "$dir/gen"
      # shellcheck disable=SC2086
      "$bin" render -q --backend "$backend" $flags --assets "$RAYCAST_CORPUS" \
        --out-dir "$dir/gen" "${gens[@]}" || failed=1
      # shellcheck disable=SC2086
      "$bin" render -q --backend "$backend" $flags -o "$dir/default.png" || failed=1
    done
  done
  (cd "$out" && find . -name '*.png' | LC_ALL=C sort | xargs sha256sum) >"$out/SHA256SUMS"
  echo "pictures: $(wc -l <"$out/SHA256SUMS") pictures in $out" >&2
  # A scene that fails (tests/scenes/missing_texture.xml does, by design,
  # unless textures are off) leaves no picture: a set compared with one
  # where it rendered shows it as missing.
  if [ "$failed" != 0 ]; then
    echo "pictures: note: some renders failed (above); their pictures are not in the set" >&2
  fi
}

# compare A B: byte for byte, by the sums each set recorded.
compare_sets() {
  local a="$1" b="$2"
  local diffs
  diffs="$(diff <(sort -k2 "$a/SHA256SUMS") <(sort -k2 "$b/SHA256SUMS") || true)"
  local total
  total="$(wc -l <"$a/SHA256SUMS")"
  if [ -z "$diffs" ]; then
    echo "pictures: PASS: $total of $total pictures byte-identical (rule: bit-exact) between $a and $b"
    return 0
  fi
  local changed
  changed="$(join -j 2 <(sort -k2 "$a/SHA256SUMS") <(sort -k2 "$b/SHA256SUMS") | awk '$2 != $3 {print $1}')"
  local only_a only_b
  only_a="$(join -v 1 -j 2 <(sort -k2 "$a/SHA256SUMS") <(sort -k2 "$b/SHA256SUMS") | awk '{print $1}')"
  only_b="$(join -v 2 -j 2 <(sort -k2 "$a/SHA256SUMS") <(sort -k2 "$b/SHA256SUMS") | awk '{print $1}')"
  local n m
  n="$(grep -c . <<<"$changed" || true)"
  m="$(grep -c . <<<"$only_a$only_b" || true)"
  echo "pictures: FAIL: $n of $total pictures differ and $m are in one set only (rule: bit-exact) between $a and $b"
  [ -n "$changed" ] && sed 's/^/  differs: /' <<<"$changed"
  [ -n "$only_a" ] && sed "s|^|  only in $a: |" <<<"$only_a"
  [ -n "$only_b" ] && sed "s|^|  only in $b: |" <<<"$only_b"
  echo "  (raycast compare A/PICTURE B/PICTURE -o diff.png shows where)"
  return 4
}

case "${1:-HEAD}" in
  build)
    build_rev "${2:?ci/pictures.sh build REV}"
    ;;
  render)
    render_set "${2:?ci/pictures.sh render BIN DIR}" "${3:?ci/pictures.sh render BIN DIR}"
    ;;
  compare)
    compare_sets "${2:?ci/pictures.sh compare A B}" "${3:?ci/pictures.sh compare A B}"
    ;;
  -h | --help)
    sed -n '2,24p' "$0" | sed 's/^# \{0,1\}//'
    ;;
  *)
    need_corpus
    rev="$1"
    commit="$(git -C "$ROOT" rev-parse --verify "$rev^{commit}")"
    ref="$PICS/sets/$commit"
    if [ ! -f "$ref/SHA256SUMS" ]; then
      bin="$(build_rev "$commit")"
      render_set "$bin" "$ref"
    fi
    build_raycast
    render_set "$BUILD/raycast" "$PICS/sets/work"
    compare_sets "$ref" "$PICS/sets/work"
    ;;
esac
