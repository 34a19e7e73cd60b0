#!/usr/bin/env bash
# Installs what mr needs, builds, and runs the test suite.
#   scripts/test.sh            release build in build/, all tests
#   scripts/test.sh --sanitize AddressSanitizer + UBSan build in build-asan/, all tests but release_only
#                              (source checks, and the large accuracy tests whose code a lighter test
#                              runs: RELEASE_ONLY in tests/CMakeLists.txt)
#   scripts/test.sh --fuzz S   libFuzzer targets (clang) in build-fuzz/, S seconds each
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-release}
jobs=$(nproc)
shared=${MR_SHARED_DATA:-$PWD/../shared/data}

bash scripts/install-deps.sh

case "$mode" in
  release|"")
    cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DMR_SHARED_DATA="$shared"
    cmake --build build -j "$jobs"
    ctest --test-dir build -j "$jobs" --output-on-failure
    ;;
  --sanitize)
    # -O1 -g1 (line tables): what ASan's documentation recommends, and 40% of
    # -O2 -g's compile time under the sanitizers (docs/benchmarks.md, CI time).
    cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMR_SANITIZE=ON \
          -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" \
          -DMR_BUILD_BENCHMARKS=OFF -DMR_SHARED_DATA="$shared"
    cmake --build build-asan -j "$jobs"
    # Leak checking is off: TBB, OpenImageIO and Embree keep process-lifetime pools.
    ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
      ctest --test-dir build-asan -j "$jobs" --output-on-failure --label-exclude release_only
    ;;
  --fuzz)
    seconds=${2:-20}  # a fixed seed keeps runs reproducible; longer runs find more
    CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMR_FUZZ=ON \
          -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" \
          -DMR_BUILD_TESTS=OFF -DMR_BUILD_BENCHMARKS=OFF
    cmake --build build-fuzz -j "$jobs" --target mr_fuzzers
    # One target per folder of fuzz/corpus (fuzz/CMakeLists.txt builds them).
    for corpus_dir in fuzz/corpus/*/; do
      name=fuzz_$(basename "$corpus_dir")
      f=build-fuzz/fuzz/$name
      corpus=fuzz/corpus/${name#fuzz_}
      work=$(mktemp -d)
      cp -r "$corpus"/. "$work"/ 2>/dev/null || true
      echo "== $name for ${seconds}s"
      ASAN_OPTIONS=detect_leaks=0 "$f" -seed=1 -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 "$work" 2>&1 | tail -3
      rm -rf "$work"
    done
    ;;
  *) echo "usage: $0 [--sanitize | --fuzz SECONDS]" >&2; exit 2 ;;
esac
