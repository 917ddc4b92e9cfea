#!/usr/bin/env bash
# RVWO's main job on its bundled default: set-up (scripts/setup.sh), a Release build, then
# rvwo-demo on three seeds: a simulated wheeled robot among walking people, solved with wheels
# only, vision with Huber, vision and wheels with Huber, and vision and wheels with the adaptive
# Barron kernel. Prints each one's trajectory error and writes out/rvwo-demo.png.
# (Until rvwo-replay lands, this is the components end to end on known data association.)
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
bash scripts/setup.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >build-configure.log || { cat build-configure.log; exit 1; }
cmake --build build --target rvwo-demo
mkdir -p out
echo "== rvwo-demo"
./build/apps/rvwo-demo --runs 3 --plot out/rvwo-demo.png "$@"
