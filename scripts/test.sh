#!/usr/bin/env bash
# Runs RVWO's whole test suite from a fresh clone: set-up (scripts/setup.sh), a RelWithDebInfo
# build in build/, ctest; then the sanitizer builds: ASan + UBSan over the suite in build-asan/,
# ThreadSanitizer over the threaded tests in build-tsan/ (RVWO_SANITIZERS=0 skips those two); then
# the readers fuzzed with libFuzzer in build-fuzz/ (scripts/fuzz.sh; RVWO_FUZZ_SECONDS=0 skips it).
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
start=$(date +%s)
stamp() { echo "== $* ($(( $(date +%s) - start )) s)"; }

stamp "set-up"
bash scripts/setup.sh
stamp "build (build/)"
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >build-configure.log || { cat build-configure.log; exit 1; }
cmake --build build
stamp "tests"
ctest --test-dir build --output-on-failure -j2

if [ "${RVWO_SANITIZERS:-1}" != 0 ]; then
  # Dependencies (Ceres, g2o, OpenCV) are not instrumented; leaks in them are not ours.
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  stamp "ASan + UBSan build (build-asan/)"
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS=-O1 -DRVWO_SANITIZE=address,undefined \
    -DRVWO_BUILD_BENCHMARKS=OFF >build-asan-configure.log || { cat build-asan-configure.log; exit 1; }
  cmake --build build-asan
  stamp "tests under ASan + UBSan"
  # The install test links the instrumented libraries into an uninstrumented consumer: skip it.
  # The replay accuracy tests (minutes of simulated video) run in the plain build only; the
  # estimator's own tests and the replay's bad-input test run here.
  ctest --test-dir build-asan --output-on-failure -j2 \
    -E 'install_consumer|clang_format|setup_failed_download|Replay\.(Static|Dynamic|Slip|Blackout|Cameras)'
  stamp "ThreadSanitizer build (build-tsan/)"
  cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS=-O1 -DRVWO_SANITIZE=thread \
    -DRVWO_BUILD_BENCHMARKS=OFF -DRVWO_BUILD_APPS=OFF -DRVWO_WITH_G2O=OFF \
    >build-tsan-configure.log || { cat build-tsan-configure.log; exit 1; }
  cmake --build build-tsan --target kernels_test semantics_test estimator_test orbslam3_local_map_test
  stamp "threaded tests under ThreadSanitizer"
  TSAN_OPTIONS=halt_on_error=1 ctest --test-dir build-tsan --output-on-failure -R 'ReliabilityManager|AsyncSegmenter|Estimator\.Threaded|WheelInputLocalMap\.ConcurrentWithTracking'
fi
if [ "${RVWO_FUZZ_SECONDS:-60}" != 0 ]; then
  stamp "fuzzing the readers (build-fuzz/, ${RVWO_FUZZ_SECONDS:-60} s each)"
  bash scripts/fuzz.sh
fi
stamp "all tests passed"
