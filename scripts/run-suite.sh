#!/usr/bin/env bash
# Replays every sequence of the scenario suite (out/suite/<name>/, made by make-suite.sh) with
# rvwo-replay in each mode and kernel, and prints the table: ATE RMSE (se3), % of the path, speed.
#   bash scripts/run-suite.sh [--deterministic] [--repeat N] [--suite DIR] [--orbslam3 VOC [--build B]] [names...]
# DIR: where the sequences are (default out/suite; e.g. out/suite-rgbd made with make-suite.sh
# --camera rgbd --out out/suite-rgbd). Trajectories, reports and plots go to
# DIR-runs/<name>/<mode>-<kernel>.{txt,log,png} (out/suite-runs/... by default).
# --repeat N: each run N times (threads make runs differ; ORB-SLAM3's most of all), the row giving
# the median ATE and, after it, the smallest and largest; the files are those of the last run, the
# others' logs <mode>-<kernel>.<i>.log.
# --orbslam3 VOC: the patched ORB-SLAM3 instead (rvwo-replay --backend orbslam3, from build dir B,
# default build, configured with ORB_SLAM3_ROOT; VOC its vocabulary), without the wheels (vo: as
# upstream) and with them (vw: poses on SE(2)), under Huber and under the adaptive kernel. "wheels"
# is the frames the wheels placed (vo: -), "poses" the frames ORB-SLAM3 kept a pose for (the ATE
# is over those; the log names the frames it did not track). ORB-SLAM3 is fed at the pace the
# sequence was recorded (rvwo-replay's default for it), so each of its runs takes the sequence's length.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
flags=() names=() suite=out/suite voc="" build=build repeat=1
while [ $# -gt 0 ]; do
  case "$1" in
    --deterministic) flags+=("$1"); shift ;;
    --repeat) repeat=$2; shift 2
      [[ $repeat =~ ^[1-9][0-9]*$ ]] || { echo "run-suite: --repeat takes a count >= 1" >&2; exit 2; } ;;
    --suite) suite=${2%/}; shift 2 ;;
    --orbslam3) voc=$2; shift 2 ;;
    --build) build=${2%/}; shift 2 ;;
    -*) echo "run-suite: unknown option $1" >&2; exit 2 ;;
    *) names+=("$1"); shift ;;
  esac
done
if [ ${#names[@]} -eq 0 ]; then
  for d in "$suite"/*/; do [ -f "$d/sequence.rawlog" ] && names+=("$(basename "$d")"); done
fi
[ ${#names[@]} -gt 0 ] || { echo "run-suite: no sequences in $suite (bash scripts/make-suite.sh makes them)" >&2; exit 2; }
cmake --build "$build" --target rvwo-replay >/dev/null
runs=(wheel vo:huber vw:huber vw:adaptive)
[ -n "$voc" ] && runs=(orbslam3-vo:huber orbslam3-vw:huber orbslam3-vw:adaptive)
printf '%-12s %-16s %10s %8s %10s %8s %7s\n' scenario run "ATE [m]" "% path" "x realtime" "wheels" poses
for n in "${names[@]}"; do
  seq="$suite/$n" out="$suite-runs/$n"
  mkdir -p "$out"
  for run in "${runs[@]}"; do
    mode=${run%%:*} kernel=${run#*:} extra=()
    [ "$mode" = wheel ] && kernel=huber
    name="$mode-$kernel"
    # Mono takes its scale from the wheels: there is no vision-only run to make.
    if [ "$mode" = vo ] && [ -z "$voc" ] && grep -Eqs '^Sensor: *"?mono' "$seq/settings.yaml"; then
      printf '%-12s %-16s %10s %8s %10s %8s %7s %s\n' "$n" "$name" - - - - - "(mono: no scale without the wheels)"
      continue
    fi
    if [ -n "$voc" ]; then
      mode=${mode#orbslam3-} name=orbslam3-$mode-$kernel extra=(--backend orbslam3 --vocabulary "$voc")
    fi
    ates=() failed=""
    for ((i = 1; i <= repeat; ++i)); do
      if "./$build/apps/rvwo-replay" --quiet "${flags[@]}" "${extra[@]}" --settings "$seq/settings.yaml" --rawlog "$seq/sequence.rawlog" \
        --gt "$seq/groundtruth.txt" --mode "$mode" --kernel "$kernel" --out "$out/$name.txt" >"$out/$name.log" 2>&1; then
        ates+=("$(awk '/ATE \(se3\)/ { print $4, $7 }' "$out/$name.log")")
        [ "$repeat" -gt 1 ] && cp "$out/$name.log" "$out/$name.$i.log"
      else
        failed=$(tail -1 "$out/$name.log")
        break
      fi
    done
    if [ -z "$failed" ]; then
      spread=""
      if [ "$repeat" -gt 1 ]; then
        spread=$(printf '%s\n' "${ates[@]}" | sort -g | awk '{ v[NR] = $1 } END { printf "(%s-%s)", v[1], v[NR] }')
      fi
      # The median run's ATE and % of the path (a lower median for an even count).
      median=$(printf '%s\n' "${ates[@]}" | sort -g | awk '{ v[NR] = $0 } END { print v[int((NR + 1) / 2)] }')
      awk -v s="$n" -v r="$name" -v ate="${median% *}" -v pct="${median#* }" -v spread="$spread" '
        /speed:/ { for (i = 1; i <= NF; ++i) if ($i ~ /x$/ && $(i+1) == "real") rt = $i }
        /^  frames [0-9]/ { poses = $2 }
        match($0, /poses kept [0-9]+/) { poses = substr($0, RSTART + 11, RLENGTH - 11) }
        /frames on wheels only/ { w = $5 }
        END { if (w == "") w = "-";
              printf "%-12s %-16s %10s %8s %10s %8s %7s %s\n", s, r, ate, pct, rt, w, poses, spread }' "$out/$name.log"
    else
      printf '%-12s %-16s failed: %s\n' "$n" "$name" "$failed"
    fi
  done
done
