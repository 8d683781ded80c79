#!/usr/bin/env bash
# weft's two front doors, for a fresh Debian 12 machine (as root) or a developer's:
#   ./weft.sh demo [args...]   install what is missing, build, render examples/scenes/showcase.json to out/demo.png
#                              (extra args go to `weft render`, e.g. --size 640x360 --quality high)
#   ./weft.sh test [--asan]    install what is missing, build, run every test suite (ctest)
#   ./weft.sh build [--asan]   install what is missing and build only
set -euo pipefail
cd "$(dirname "$0")"

command_name="${1:-}"
shift || true

preset=default
for arg in "$@"; do
  case "$arg" in
    --asan) preset=asan ;;
  esac
done

jobs=$(nproc 2>/dev/null || echo 2)

build() {
  ./tools/bootstrap.sh
  cmake --preset "$preset" >/dev/null
  cmake --build --preset "$preset" -j "$jobs"
}

case "$command_name" in
  build)
    build
    ;;
  demo)
    build
    mkdir -p out
    args=()
    for arg in "$@"; do [ "$arg" != "--asan" ] && args+=("$arg"); done
    bin=build/bin
    [ "$preset" = asan ] && bin=build/asan/bin
    "$bin/weft" render examples/scenes/showcase.json -o out/demo.png --profile "${args[@]+"${args[@]}"}"
    echo "demo: wrote $(pwd)/out/demo.png"
    ;;
  test)
    build
    ctest --preset "$preset" -j "$jobs"
    ;;
  *)
    echo "usage: ./weft.sh demo | test [--asan] | build [--asan]" >&2
    exit 2
    ;;
esac
