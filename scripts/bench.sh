#!/usr/bin/env bash
# RVWO's performance table, in one run on one machine (docs/performance.md keeps one):
#   bash scripts/bench.sh [--duration S] [--cpus LIST] [--realtime X] [--cameras LIST]
#                         [--orbslam3 VOC [--build B]] [--out DIR]
# Simulates the `dynamic` scenario (walkers, with their label images) for each camera: stereo
# pinhole 640x480, stereo fisheye 848x800, RGB-D, mono; all at 30 Hz. Replays each with everything
# on (--mode vw, adaptive kernels, semantics from the labels, threads) as fast as it goes (or at
# --realtime's pace), and
# prints a Markdown table from rvwo-replay's report: real-time factor, frames/s, CPU-seconds a
# second of data, the tracking thread's time a frame (p50/p95/max), features and local BA, peak
# memory, the map at the end and the ATE. Then the kernel against Ceres' own losses
# (rvwo_bench_kernels). Timings from two runs of this script compare only on one idle machine.
#   --duration S   seconds simulated per camera (default 60)
#   --cpus LIST    run the replays under taskset -c LIST (e.g. 0: the tracking bound on one core)
#   --realtime X   every replay fed X times as fast as recorded (default 0: as fast as it goes; 1: at
#                  the camera's pace, as on a robot)
#   --cameras LIST some of stereo:pinhole stereo:fisheye rgbd:pinhole mono:pinhole (default all four)
#   --orbslam3 VOC also ORB-SLAM3 (rvwo-replay --backend orbslam3 from build dir B, configured with
#                  ORB_SLAM3_ROOT), without the wheels (as upstream) and with them
#   --out DIR      sequences and reports (default out/bench); the table is DIR/table.md
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
duration=60 cpus="" voc="" build=build out=out/bench realtime=0
all_cameras="stereo:pinhole stereo:fisheye rgbd:pinhole mono:pinhole" cameras=$all_cameras
while [ $# -gt 0 ]; do
  case "$1" in
    --duration) duration=$2; shift 2 ;;
    --cpus) cpus=$2; shift 2 ;;
    --realtime) realtime=$2; shift 2 ;;
    --cameras) cameras=$2; shift 2 ;;
    --orbslam3) voc=$2; shift 2 ;;
    --build) build=${2%/}; shift 2 ;;
    --out) out=${2%/}; shift 2 ;;
    *) echo "bench: unknown argument $1 (see the header of scripts/bench.sh)" >&2; exit 2 ;;
  esac
done
[[ $duration =~ ^[0-9]+([.][0-9]+)?$ ]] || { echo "bench: --duration takes seconds" >&2; exit 2; }
[[ $realtime =~ ^[0-9]+([.][0-9]+)?$ ]] || { echo "bench: --realtime takes a factor (0: flat out)" >&2; exit 2; }
[ -n "${cameras// /}" ] || { echo "bench: --cameras takes at least one of: $all_cameras" >&2; exit 2; }
for cam in $cameras; do
  [[ " $all_cameras " == *" $cam "* ]] || { echo "bench: --cameras: $cam is not one of: $all_cameras" >&2; exit 2; }
done
if [ -n "$voc" ] && [ ! -f "$voc" ]; then echo "bench: no vocabulary $voc" >&2; exit 2; fi
if [ ! -x "$build/apps/rvwo-replay" ]; then
  bash scripts/setup.sh
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
fi
cmake --build "$build" --target rvwo-sim rvwo-replay rvwo_bench_kernels >/dev/null
if [ -n "$voc" ] && ! "$build/apps/rvwo-replay" --help | grep -q -- --backend; then
  echo "bench: $build/apps/rvwo-replay has no ORB-SLAM3 backend (configure $build with ORB_SLAM3_ROOT)" >&2
  exit 2
fi
mkdir -p "$out"
pin=()
[ -n "$cpus" ] && pin=(taskset -c "$cpus")

# One stage's "p50/p95/max" from a report's timings table, or - if it has none.
stage() { awk -v s="$2" '$0 ~ "^  "s" +[0-9]" { n = split($0, f, " +"); printf "%s/%s/%s", f[n-3], f[n-2], f[n-1]; found = 1 }
  END { if (!found) printf "-" }' "$1"; }

table="$out/table.md"
{
  echo "Commit $(git rev-parse --short HEAD)$(git diff --quiet HEAD -- . ':!out' || echo ' (with changes)'), $(date -u +%Y-%m-%d)," \
    "$(nproc) CPUs ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'))${cpus:+, taskset -c $cpus}:" \
    "\`bash scripts/bench.sh --duration $duration${cpus:+ --cpus $cpus}$([ "$realtime" = 0 ] || echo " --realtime $realtime")$([ "$cameras" = "$all_cameras" ] || echo " --cameras '$cameras'")\`"
  echo
  echo "| run | x real time | frames/s | CPU s per s | tracking ms p50/p95/max | features p95 | local BA ms p50/p95 | peak MB | keyframes | map kf / points | ATE % path |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|"
} >"$table"

row() {  # name, report
  local r=$2
  local speed; speed=$(grep -m1 '  speed:' "$r")
  local x fps cpu mem
  x=$(sed -E 's/.*: ([0-9.]+)x real time.*/\1/' <<<"$speed")
  fps=$(sed -E 's/.*, ([0-9.]+) frames\/s.*/\1/' <<<"$speed")
  cpu=$(sed -E 's/.*CPU ([0-9.]+) s.*/\1/' <<<"$speed")
  mem=$(sed -E 's/.*peak memory ([0-9]+) MB.*/\1/' <<<"$speed")
  local data; data=$(sed -E 's/.*speed: ([0-9.]+) s of data.*/\1/' <<<"$speed")
  local per; per=$(awk -v c="$cpu" -v d="$data" 'BEGIN { printf "%.2f", c / d }')
  local track; track=$(stage "$r" tracking)
  [ "$track" = - ] && track=$(stage "$r" TrackFrame)
  local ba; ba=$(stage "$r" "local BA" | cut -d/ -f1,2)
  local map; map=$(grep -m1 'map at the end' "$r" | sed -E 's/.*: ([0-9]+) keyframes and ([0-9]+) points.*/\1 \/ \2/' || true)
  local ate; ate=$(grep -m1 '  ATE' "$r" | sed -E 's/.* = ([0-9.]+) % .*/\1/' || true)
  local kfs; kfs=$(grep -m1 ' s, keyframes [0-9]' "$r" | sed -E 's/.* s, keyframes ([0-9]+).*/\1/' || true)
  echo "| $1 | $x | $fps | $per | $track | $(stage "$r" features | cut -d/ -f2) | ${ba:--} | $mem | ${kfs:--} | ${map:--} | ${ate:--} |" >>"$table"
}

for cam in $cameras; do
  camera=${cam%%:*} lens=${cam##*:} name=${cam/:/-}
  seq="$out/$name"
  if [ "$(cat "$seq/bench-duration" 2>/dev/null)" != "$duration" ]; then  # made before, of this length
    echo "bench: simulating $name ($duration s)" >&2
    "$build/apps/rvwo-sim" --quiet --scenario scenarios/dynamic.yaml --camera "$camera" --lens "$lens" \
      --duration "$duration" --out "$seq"
    echo "$duration" >"$seq/bench-duration"
  fi
  args=(--quiet --settings "$seq/settings.yaml" --rawlog "$seq/sequence.rawlog" --gt "$seq/groundtruth.txt"
    --realtime "$realtime")
  echo "bench: replaying $name" >&2
  "${pin[@]}" "$build/apps/rvwo-replay" "${args[@]}" --out "$seq/rvwo.txt" >"$seq/rvwo.log"
  row "RVWO, $name" "$seq/rvwo.log"
  if [ -n "$voc" ] && [ "$lens" = pinhole ]; then
    for mode in vo vw; do
      echo "bench: replaying $name through ORB-SLAM3, --mode $mode" >&2
      "${pin[@]}" "$build/apps/rvwo-replay" "${args[@]}" --backend orbslam3 --vocabulary "$voc" \
        --mode "$mode" --out "$seq/orbslam3-$mode.txt" >"$seq/orbslam3-$mode.log"
      row "ORB-SLAM3 $([ $mode = vo ] && echo upstream || echo 'with RVWO'), $name" "$seq/orbslam3-$mode.log"
    done
  fi
done

# The kernel in Ceres' loop against Ceres' own loss of the same shape, timed in alternating blocks.
echo "bench: the kernel against Ceres" >&2
"${pin[@]}" "$build/benchmarks/rvwo_bench_kernels" --benchmark_filter='BM_BarronOverCeres' --benchmark_format=csv \
  2>/dev/null >"$out/kernels.csv"
awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) { gsub(/"/, "", $i); col[$i] = i }; next }
  /BarronOverCeres/ {
    if (!printed++) printf "\n| shape | BarronLoss ns | Ceres ns | ratio |\n|---|---|---|---|\n"
    label = $col["label"]; gsub(/"/, "", label)
    printf "| %s | %.2f | %.2f | %.2f |\n", label, $col["barron_ns"], $col["ceres_ns"], $col["ratio"]
  }' "$out/kernels.csv" >>"$table"
cat "$table"
