#!/usr/bin/env bash
# The main job on the bundled default dataset: installs what is missing, builds, then
#   1. adds 1000 random false loop closures to Olson's Manhattan M3500 graph (seed 1),
#   2. lets RRR decide which loops are real (rrr_offline, batch),
#   3. prints precision / recall / ATE against the bundled truth and writes a PNG,
#   4. runs the same live: launch/demo.launch (nodelet + replay + rviz, or headless + PNG).
# Usage: scripts/demo.sh [--kind random|local|random-grouped|local-grouped] [--count N]
# Output folder: $RRR_DEMO_DIR (default <workspace>/demo).
source "$(dirname "$0")/common.sh"
rrr_install_missing
rrr_build >/dev/null

kind=random
count=1000
while [[ $# -gt 0 ]]; do
  case "$1" in
    --kind) kind=$2; shift 2 ;;
    --count) count=$2; shift 2 ;;
    *) echo "usage: $0 [--kind KIND] [--count N]" >&2; exit 2 ;;
  esac
done

out=${RRR_DEMO_DIR:-${RRR_WS}/demo}
mkdir -p "$out"
data=${RRR_REPO}/test/data
graph=$out/m3500_${kind}${count}.g2o
python3 "${RRR_REPO}/scripts/add_outliers" "$data/manhattanOlson3500_olson.g2o.gz" "$graph" \
  --kind "$kind" --count "$count" --seed 1
rosrun rrr_graphslam rrr_offline "$graph" --decisions "$out/decisions.tsv" --output "$out/optimized.g2o"
python3 "${RRR_REPO}/scripts/evaluate" --truth "$graph.labels" --decisions "$out/decisions.tsv" \
  --graph "$out/optimized.g2o" --ground-truth "$data/manhattanOlson3500_nodes_groundTruth.dat.gz" \
  --plot "$out/decisions.png" --title "M3500 + $count $kind outliers: RRR decisions"

# The same on ROS: the nodelet fed by a replay of M3500 with 200 false loops. With a display, rviz
# shows it; without one, the replay's evaluation is printed and the rviz window saved as a PNG.
if [[ -n "${DISPLAY:-}" ]]; then
  roslaunch rrr_graphslam demo.launch
else
  python3 "${RRR_REPO}/scripts/snapshot_rviz" "$out/demo_rviz.png" | grep -E '^(sent|node:|precision|snapshot)'
fi
