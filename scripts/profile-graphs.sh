#!/usr/bin/env bash
# Profiles every graph under graphs/ at 3840x1728 on cv1-class (TI's reference pipelines,
# tda4vm-*.json, on tda4vm-c7x at TI's 1280x720, 15 fps) with --enforce and prints each
# Markdown summary. Fails if any enforced graph is over budget. A graph file with "budget":
# {"enforce": false} is profiled and reported, not enforced; its note says why (the what-ifs such
# as disparity-vector-sgm.json, SGM on the vector engine, and the chains still over a budget). The
# graphs holding the 3840x1728 disparity run it on cv1-class's warp and stereo units.
# Usage: profile-graphs.sh LPSTEREO_BINARY
set -euo pipefail
cd "$(dirname "$0")/.."
binary=${1:?usage: profile-graphs.sh LPSTEREO_BINARY}
summary_dir=$(mktemp -d)
trap 'rm -rf "$summary_dir"' EXIT
status=0
for graph in graphs/*.json; do
  name=$(basename "$graph" .json)
  # TI's reference pipelines (tda4vm-*.json) are profiled where TI measured them: on tda4vm-c7x at
  # 1280x720, 15 fps (TI Robotics SDK); every other graph on cv1-class at 3840x1728, 30 fps.
  case "$name" in
    tda4vm-*) where=(--target tda4vm-c7x --width 1280 --height 720 --fps 15) ;;
    *) where=(--target cv1-class --width 3840 --height 1728 --fps 30) ;;
  esac
  if "$binary" profile --graph "$graph" "${where[@]}" --enforce --summary-md "$summary_dir/$name.md" >/dev/null; then
    :
  else
    code=$?
    echo "graph $name: lpstereo profile exited $code"
    status=1
  fi
  [ -f "$summary_dir/$name.md" ] && cat "$summary_dir/$name.md" && echo
done
exit $status
