#!/usr/bin/env bash
# weft's two front doors, for a fresh Debian 12 machine (as root) or a developer's:
#   ./weft.sh demo [args...]   install what is missing, build, render examples/scenes/showcase.json to out/demo.png
#                              (extra args go to `weft render`, e.g. --size 640x360 --quality high)
#   ./weft.sh test [--asan|--tsan]   install what is missing, build, run every test suite (ctest);
#                              --asan: ASan + UBSan in build/asan, --tsan: ThreadSanitizer in build/tsan
#   ./weft.sh build [--asan|--tsan]  install what is missing and build only
#   ./weft.sh fuzz [--seconds N] [--runs N] [HARNESS...]
#                              build the libFuzzer harnesses (preset fuzz, tests/fuzz) and run each
#                              for N seconds (default 60) or N executions from its seed corpus
#                              (docs/benchmarks.md: --runs 1000000); new inputs go to
#                              build/fuzz/corpus/, crashes to build/fuzz/crashes/ (copy a crash into
#                              tests/fuzz/crashes/<corpus>/ once fixed: ctest replays it)
set -euo pipefail
cd "$(dirname "$0")"

command_name="${1:-}"
shift || true

preset=default
for arg in "$@"; do
  case "$arg" in
    --asan) preset=asan ;;
    --tsan) preset=tsan ;;
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
    for arg in "$@"; do [ "$arg" != "--asan" ] && [ "$arg" != "--tsan" ] && args+=("$arg"); done
    bin=build/bin
    [ "$preset" != default ] && bin=build/$preset/bin
    "$bin/weft" render examples/scenes/showcase.json -o out/demo.png --profile "${args[@]+"${args[@]}"}"
    echo "demo: wrote $(pwd)/out/demo.png"
    ;;
  test)
    build
    ctest --preset "$preset" -j "$jobs"
    ;;
  fuzz)
    seconds=""
    runs=""
    only=()
    while [ $# -gt 0 ]; do
      case "$1" in
        --seconds) seconds="${2:?--seconds needs a number}"; shift 2 ;;
        --seconds=*) seconds="${1#--seconds=}"; shift ;;
        --runs) runs="${2:?--runs needs a number}"; shift 2 ;;
        --runs=*) runs="${1#--runs=}"; shift ;;
        -*) echo "./weft.sh fuzz: unknown option $1" >&2; exit 2 ;;
        *) only+=("$1"); shift ;;
      esac
    done
    ./tools/bootstrap.sh
    cmake --preset fuzz >/dev/null
    if [ ${#only[@]} -gt 0 ]; then
      cmake --build --preset fuzz -j "$jobs" --target "${only[@]}"
    else
      cmake --build --preset fuzz -j "$jobs"
    fi
    # --runs N: stop each harness after N executions (no time limit unless --seconds is given too);
    # otherwise each runs --seconds (default 60).
    limits=()
    if [ -n "$runs" ]; then limits+=(-runs="$runs"); fi
    if [ -n "$seconds" ]; then limits+=(-max_total_time="$seconds"); elif [ -z "$runs" ]; then limits+=(-max_total_time=60); fi
    mkdir -p build/fuzz/crashes
    status=0
    while read -r name seeds; do
      [ -z "$name" ] && continue
      if [ ${#only[@]} -gt 0 ] && [[ ! " ${only[*]} " =~ " $name " ]]; then continue; fi
      work="build/fuzz/corpus/$name"
      mkdir -p "$work"
      echo "== $name (${limits[*]})"
      start=$(date +%s)
      log="build/fuzz/$name.log"
      rc=0
      build/fuzz/bin/"$name" "${limits[@]}" -print_final_stats=1 -timeout=10 -rss_limit_mb=4096 \
        -artifact_prefix="build/fuzz/crashes/$name-" "$work" "$seeds" >"$log" 2>&1 || rc=$?
      grep -E '^(stat::number_of_executed_units|stat::peak_rss_mb|SUMMARY|Test unit written|Done )' "$log" || true
      echo "   $(( $(date +%s) - start )) s wall"
      if [ "$rc" -ne 0 ]; then echo "!! $name stopped with $rc: see $log and build/fuzz/crashes/"; status=1; fi
    done < build/fuzz/fuzzers.txt
    exit $status
    ;;
  *)
    echo "usage: ./weft.sh demo | test [--asan|--tsan] | build [--asan|--tsan] | fuzz [--seconds N] [--runs N] [HARNESS...]" >&2
    exit 2
    ;;
esac
