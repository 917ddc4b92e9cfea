#!/usr/bin/env bash
# Replays every sequence of the scenario suite (out/suite/<name>/, made by make-suite.sh) with
# rvwo-replay in each mode and kernel, and prints the table: ATE RMSE (se3), % of the path, speed.
#   bash scripts/run-suite.sh [--deterministic] [--suite DIR] [names...]
# DIR: where the sequences are (default out/suite; e.g. out/suite-rgbd made with make-suite.sh
# --camera rgbd --out out/suite-rgbd). Trajectories, reports and plots go to
# DIR-runs/<name>/<mode>-<kernel>.{txt,log,png} (out/suite-runs/... by default).
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
flags=() names=() suite=out/suite
while [ $# -gt 0 ]; do
  case "$1" in
    --deterministic) flags+=("$1"); shift ;;
    --suite) suite=${2%/}; shift 2 ;;
    -*) echo "run-suite: unknown option $1" >&2; exit 2 ;;
    *) names+=("$1"); shift ;;
  esac
done
if [ ${#names[@]} -eq 0 ]; then
  for d in "$suite"/*/; do [ -f "$d/sequence.rawlog" ] && names+=("$(basename "$d")"); done
fi
[ ${#names[@]} -gt 0 ] || { echo "run-suite: no sequences in $suite (bash scripts/make-suite.sh makes them)" >&2; exit 2; }
cmake --build build --target rvwo-replay >/dev/null
printf '%-12s %-16s %10s %8s %10s %8s\n' scenario run "ATE [m]" "% path" "x realtime" "wheels"
for n in "${names[@]}"; do
  seq="$suite/$n" out="$suite-runs/$n"
  mkdir -p "$out"
  for run in wheel vo:huber vw:huber vw:adaptive; do
    mode=${run%%:*} kernel=${run#*:}
    [ "$mode" = wheel ] && kernel=huber
    name="$mode-$kernel"
    if ./build/apps/rvwo-replay --quiet "${flags[@]}" --settings "$seq/settings.yaml" --rawlog "$seq/sequence.rawlog" \
      --gt "$seq/groundtruth.txt" --mode "$mode" --kernel "$kernel" --out "$out/$name.txt" >"$out/$name.log" 2>&1; then
      awk -v s="$n" -v r="$name" '
        /ATE \(se3\)/ { ate = $4; pct = $7 }
        /speed:/ { for (i = 1; i <= NF; ++i) if ($i ~ /x$/ && $(i+1) == "real") rt = $i }
        /frames on wheels only/ { w = $5 }
        END { printf "%-12s %-16s %10s %8s %10s %8s\n", s, r, ate, pct, rt, w }' "$out/$name.log"
    else
      printf '%-12s %-16s failed: %s\n' "$n" "$name" "$(tail -1 "$out/$name.log")"
    fi
  done
done
