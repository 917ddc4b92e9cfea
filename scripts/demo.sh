#!/usr/bin/env bash
# RVWO's main job on its bundled default: set-up (scripts/setup.sh), a build, then
#   1. rvwo-sim renders a short sequence of the suite's `combined` scenario (real robot motion from
#      OpenLORIS home1, people walking across the view and around the robot, a wheel slip at
#      20-22 s, the lens covered at 30-33 s) into out/demo/,
#   2. rvwo-replay replays it three ways: wheels only, vision only (vo), vision and wheels (vw,
#      RVWO: adaptive kernels, semantic labels), and prints their ATE side by side.
# Reports and plots: out/demo/<mode>.log, out/demo/<mode>.png. Arguments go to rvwo-sim (e.g.
# --duration 60, --camera rgbd, --seed 2).
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
bash scripts/setup.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >build-configure.log || { cat build-configure.log; exit 1; }
cmake --build build --target rvwo-sim rvwo-replay
seq=out/demo
rm -rf "$seq"
echo "== rvwo-sim: scenarios/combined.yaml, 36 s, into $seq/"
./build/apps/rvwo-sim --scenario scenarios/combined.yaml --out "$seq" --duration 36 --seed 1 --quiet "$@"
for mode in wheel vo vw; do
  echo "== rvwo-replay --mode $mode"
  ./build/apps/rvwo-replay --settings "$seq/settings.yaml" --rawlog "$seq/sequence.rawlog" --gt "$seq/groundtruth.txt" \
    --mode "$mode" --out "$seq/$mode.txt" | tee "$seq/$mode.log" | grep -E "ATE|speed|wheels only"
done
echo
echo "== ATE (se3 alignment) on $seq, $(grep -c -v '^#' "$seq/groundtruth.txt") frames"
printf '%-8s %12s %10s\n' mode "RMSE [m]" "% of path"
for mode in wheel vo vw; do
  awk -v m="$mode" '/ATE \(se3\)/ { printf "%-8s %12s %10s\n", m, $4, $7 }' "$seq/$mode.log"
done
echo "plots: $seq/wheel.png $seq/vo.png $seq/vw.png"
