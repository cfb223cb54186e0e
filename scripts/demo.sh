#!/usr/bin/env bash
# The main job on the bundled default dataset: installs what is missing, builds, then optimizes
# Olson's Manhattan M3500 graph and prints chi-square before and after, iterations and time.
# Usage: scripts/demo.sh [GRAPH]   (default: test/data/manhattanOlson3500_olson.g2o.gz)
source "$(dirname "$0")/common.sh"
rrr_install_missing
rrr_build >/dev/null

input=${1:-${RRR_REPO}/test/data/manhattanOlson3500_olson.g2o.gz}
output=${RRR_DEMO_OUTPUT:-${RRR_WS}/demo_optimized.g2o}
rosrun rrr_graphslam rrr_optimize "$input" --output "$output"
