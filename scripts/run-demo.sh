#!/usr/bin/env bash
# The main job on built-in data: installs the Debian packages, builds the release preset, and runs
# `lpstereo disparity` on the synthetic stereo scene, writing into out/: disparity.png (KITTI
# 16-bit), disparity_color.png, the input views, the ground truth, and the cv1-class profile
# (profile.json, trace.json for Perfetto, profile.md). The matcher runs in the chip configuration
# (--config chip: what cv1-class's stereo unit runs), so the profile costs the graph that made the
# disparity, on the units that run it.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ "$(id -u)" -eq 0 ]; then ./scripts/install-deps.sh; else ./scripts/install-deps.sh || exit 1; fi
cmake --preset release >/dev/null
cmake --build --preset release -j "$(nproc)"
./build/release/tools/lpstereo disparity --synthetic --width 1280 --height 720 --target cv1-class --config chip --out-dir out "$@"
