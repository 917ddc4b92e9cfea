#!/usr/bin/env bash
# Generates RVWO's scenario suite (scenarios/*.yaml) with rvwo-sim into out/suite/<name>/:
#   bash scripts/make-suite.sh [--seed N] [--camera stereo|rgbd|mono] [--duration S] [--out DIR] [names...]
# (DIR: default out/suite; another camera is best kept apart, e.g. --camera rgbd --out out/suite-rgbd)
# Builds rvwo-sim first (running the set-up if needed). About 11 MB per simulated second of
# stereo; the whole suite (570 s) is about 5.6 GB and takes about 13 minutes on two cores (estimated).
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
seed=1 extra=() names=() dest=out/suite
while [ $# -gt 0 ]; do
  case "$1" in
    --seed) seed=$2; shift 2 ;;
    --camera|--duration) extra+=("$1" "$2"); shift 2 ;;
    --out) dest=${2%/}; shift 2 ;;
    -*) echo "make-suite: unknown option $1" >&2; exit 2 ;;
    *) names+=("$1"); shift ;;
  esac
done
[ ${#names[@]} -gt 0 ] || names=(static dynamic blackout lowtexture slip combined)
if [ ! -x build/apps/rvwo-sim ]; then
  bash scripts/setup.sh
  cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >build-configure.log || { cat build-configure.log; exit 1; }
fi
cmake --build build --target rvwo-sim
for n in "${names[@]}"; do
  [ -f "scenarios/$n.yaml" ] || { echo "make-suite: no scenario scenarios/$n.yaml" >&2; exit 2; }
  echo "== $n"
  ./build/apps/rvwo-sim --scenario "scenarios/$n.yaml" --out "$dest/$n" --seed "$seed" "${extra[@]}"
done
du -sh "$dest"
