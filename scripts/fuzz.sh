#!/usr/bin/env bash
# Fuzzes RVWO's readers (tests/fuzz: rawlog, settings, trajectory, rvwo-convert's folder lists,
# image files) with libFuzzer under ASan and UBSan: a clang build of the fuzz targets in build-fuzz/,
# then each target for RVWO_FUZZ_SECONDS (60) from its regression corpus
# (tests/fuzz/regressions/<target>/) and seeds the simulator makes (build/'s rvwo-sim, when built),
# with libFuzzer's seed RVWO_FUZZ_SEED (1). Prints the runs per target; exits 1
# on a crash, whose input is kept in build-fuzz/crashes/<target>/ (once fixed, add it to the
# regression corpus).
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
SECONDS_EACH=${RVWO_FUZZ_SECONDS:-60}
SEED=${RVWO_FUZZ_SEED:-1}
OUT=build-fuzz
CC=clang CXX=clang++ cmake -S . -B "$OUT" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DRVWO_FUZZ=ON \
  -DRVWO_SANITIZE=address,undefined -DRVWO_BUILD_BENCHMARKS=OFF -DRVWO_WITH_G2O=OFF \
  >"$OUT-configure.log" 2>&1 || { cat "$OUT-configure.log"; exit 1; }
cmake --build "$OUT" --target fuzz_rawlog fuzz_settings fuzz_trajectory fuzz_convert fuzz_image

seeds="$OUT/seeds"
rm -rf "$seeds"
if [ -x build/apps/rvwo-sim ]; then
  build/apps/rvwo-sim --quiet --scenario scenarios/static.yaml --out "$seeds" --seed 7 --duration 0.5 >/dev/null
fi
status=0
for target in rawlog settings trajectory convert image; do
  corpus="$OUT/corpus/$target" crashes="$OUT/crashes/$target"
  rm -rf "$crashes"
  mkdir -p "$corpus" "$crashes"
  cp tests/fuzz/regressions/$target/* "$corpus/"
  case $target in
    rawlog) [ -f "$seeds/sequence.rawlog" ] && cp "$seeds/sequence.rawlog" "$corpus/seed.rawlog" ;;
    settings) [ -f "$seeds/settings.yaml" ] && cp "$seeds/settings.yaml" "$seeds/scenario.yaml" "$corpus/" ;;
    trajectory) [ -f "$seeds/groundtruth.txt" ] && cp "$seeds/groundtruth.txt" "$corpus/" ;;
    convert) [ -f "$seeds/groundtruth.txt" ] && { printf '\002' | cat - "$seeds/groundtruth.txt" >"$corpus/seed_csv"; } ;;
  esac
  log="$OUT/fuzz_$target.log"
  # Fork mode goes on past an input that asks for more memory than the limit: MRPT 2.5 allocates a
  # length read from the file (a string's, a vector's) before reading what it counts (docs/rawlog.md).
  # Such inputs are kept, and below each must be that known case, allocated in MRPT's readers; any
  # other failure is a finding.
  # MRPT and OpenCV keep allocations for the process's life: leaks are not what is looked for here.
  # An allocation no machine can serve (an image size read from the file) returns null, as the
  # allocator of a user's run does, so that OpenCV throws and the reader reports the record.
  ASAN_OPTIONS=detect_leaks=0:quarantine_size_mb=16:allocator_may_return_null=1 "$OUT/tests/fuzz/fuzz_$target" -fork=1 -ignore_ooms=1 \
    -seed="$SEED" -max_total_time="$SECONDS_EACH" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=512 \
    -artifact_prefix="$crashes/" "$corpus" >"$log" 2>&1 || true
  runs=$(grep -o '^#[0-9]*' "$log" | tail -1 | tr -d '#')
  known=0 found=0
  for input in "$crashes"/*; do
    [ -e "$input" ] || continue
    # Bounded twice: a timeout input would otherwise run again without end.
    trace=$(ASAN_OPTIONS=detect_leaks=0:allocator_may_return_null=1 timeout 60 "$OUT/tests/fuzz/fuzz_$target" -timeout=10 -malloc_limit_mb=512 \
      -rss_limit_mb=2048 "$input" 2>&1 || true)
    if [[ $(basename "$input") == oom-* && $trace == *'mrpt::serialization::'* ]]; then
      known=$((known + 1))
      rm "$input"
    else
      found=$((found + 1))
      # What CI's log needs to tell the finding: its kind, where, and the seed to fuzz it again.
      echo "fuzz: $target: $(basename "$input"): $(grep -m1 '^SUMMARY' <<<"$trace" || echo 'no sanitizer summary')"
      grep -m4 -E '^ +#[0-9]+ ' <<<"$trace" | sed 's/^ */fuzz:     /' || true
    fi
  done
  seed=$(grep -m1 -o 'Seed: [0-9]*' "$log" | tr -dc 0-9)
  echo "fuzz: $target: ${runs:-?} runs in $SECONDS_EACH s (-seed=${seed:-?}), corpus $(ls "$corpus" | wc -l) inputs," \
    "$known over the memory limit in MRPT's readers (known), $found other failures"
  if [ "$found" -gt 0 ]; then
    status=1
    echo "fuzz: $target: the failing inputs are in $crashes/ (the log: $log)"
  fi
done
exit $status
