#!/usr/bin/env bash
# Runs RVWO's tests from a fresh clone, in three tiers (ctest labels): unit (seconds each: maths,
# adapters, readers), system (short replays and the apps), long (minutes of simulated video: the
# accuracy bounds). Set-up (scripts/setup.sh), a RelWithDebInfo build in build/ and every tier;
# then a build under ASan + UBSan in build-asan/ with the unit and system tiers, ThreadSanitizer
# over the threaded tests in build-tsan/ (RVWO_SANITIZERS=0 skips both), and the readers fuzzed in
# a clang build for 60 s each from a fixed seed (scripts/fuzz.sh; RVWO_FUZZ_SECONDS=0 skips it).
# docs/decisions/0013.
#   --ci  what .ci/run does: the long tier on the scenarios' short cuts (RVWO_REPLAY_CUTS=short),
#         the unit tier alone under ASan + UBSan, fuzzing as the whole run does. Run the
#         whole of it before submitting a change to the estimator, the plugin or the simulator.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
ci=0
case "${1:-}" in
  --ci) ci=1 ;;
  "") ;;
  *) echo "scripts/test.sh: error: $1: unknown option (only --ci)" >&2; exit 1 ;;
esac
start=$(date +%s)
stamp() { echo "== $* ($(( $(date +%s) - start )) s)"; }

stamp "set-up"
bash scripts/setup.sh
stamp "build (build/)"
# Line tables only (-g1): enough for a backtrace, at a fraction of full debug info's compile time.
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" \
  >build-configure.log || { cat build-configure.log; exit 1; }
cmake --build build
unlabelled=$(ctest --test-dir build -N -LE '^(unit|system|long)$' | grep -c 'Test *#' || true)
if [ "$unlabelled" != 0 ]; then
  echo "scripts/test.sh: error: $unlabelled tests have no tier (ctest --test-dir build -N -LE 'unit|system|long')" >&2
  exit 1
fi
if [ $ci = 1 ]; then
  stamp "tests: unit, system, and long on short cuts"
  RVWO_REPLAY_CUTS=short ctest --test-dir build --output-on-failure -j2
else
  stamp "tests: unit, system, long"
  ctest --test-dir build --output-on-failure -j2
fi

if [ "${RVWO_SANITIZERS:-1}" != 0 ]; then
  # Dependencies (Ceres, g2o, OpenCV) are not instrumented; leaks in them are not ours. An
  # allocation no machine can serve returns null, as outside ASan (a reader's tests rely on it).
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:allocator_may_return_null=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  # The install and package tests link the instrumented libraries into uninstrumented consumers;
  # the checks of the tree (format, sizes, docs) and the set-up's are as in the plain build.
  skip='install_consumer|deb_package|shipped_model_installed|clang_format|setup_failed_download|code_sizes|cited_docs|readme_'
  if [ $ci = 1 ]; then tiers=unit; else tiers='unit|system'; fi
  stamp "ASan + UBSan build (build-asan/): $tiers"
  # Asserts on (Eigen's among them), -O1 with line tables only (enough for the stack traces).
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" \
    -DRVWO_SANITIZE=address,undefined -DRVWO_BUILD_BENCHMARKS=OFF \
    >build-asan-configure.log || { cat build-asan-configure.log; exit 1; }
  cmake --build build-asan --target $(tr '|' '\n' <<<"$tiers" | sed 's/^/tests_/')
  stamp "tests under ASan + UBSan: $tiers"
  ctest --test-dir build-asan --output-on-failure -j2 -L "^($tiers)\$" -E "$skip"
  stamp "ThreadSanitizer build (build-tsan/)"
  cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" -DRVWO_SANITIZE=thread \
    -DRVWO_BUILD_BENCHMARKS=OFF -DRVWO_BUILD_APPS=OFF -DRVWO_WITH_G2O=OFF \
    >build-tsan-configure.log || { cat build-tsan-configure.log; exit 1; }
  cmake --build build-tsan --target kernels_test semantics_test estimator_test orbslam3_local_map_test
  stamp "threaded tests under ThreadSanitizer"
  TSAN_OPTIONS=halt_on_error=1 ctest --test-dir build-tsan --output-on-failure -R 'ReliabilityManager|AsyncSegmenter|Estimator\.Threaded|WheelInputLocalMap\.ConcurrentWithTracking'
fi
# The regression corpora also run as unit tests, plain and under ASan + UBSan.
export RVWO_FUZZ_SECONDS=${RVWO_FUZZ_SECONDS:-60}
if [ "$RVWO_FUZZ_SECONDS" != 0 ]; then
  stamp "fuzzing the readers (build-fuzz/, $RVWO_FUZZ_SECONDS s each)"
  bash scripts/fuzz.sh
fi
stamp "all tests passed"
