#!/usr/bin/env bash
# Runs raycast, installing the Debian packages it needs and building it first
# when needed: `ci/raycast.sh render -o default.png`.
source "$(dirname "$0")/common.sh"
build_raycast
exec "$BUILD/raycast" "$@"
