#!/bin/sh
# Whole-process disparity timings as a user runs them: one `lpstereo disparity L R -o OUT.png`
# (start-up, PNG reads, the first and only frame, the PNG write) against OpenCV's StereoSGBM in its
# three modes as a one-shot program of the same shape (bench/opencv_disparity_oneshot.cpp), each
# with 2 threads, wall time and peak resident memory from GNU time, medians of --repeats runs taken
# in turn (lpstereo, OpenCV, lpstereo, ...), ratios printed. Then the streaming rate at 4K:
# `lpstereo run` over --stream-pairs pairs (PNG decoding included; the status line's rate).
# Pairs: `lpstereo synth` road scenes with sensor noise (sigma 2 grey levels) at 640x480 x 128,
# 1242x375 x 128, 1282x1110 x 256 and 3840x1728 x 128, rendered once before the timings.
# Also printed: each program's start-up peak memory (no work), which the shared libraries set.
# Usage: bench/oneshot-disparity.sh [--build DIR] [--repeats N] [--sizes "WxHxD ..."] [--stream-pairs N]
#        [--no-hh] (skip MODE_HH, whose 4K run holds a W x H x D volume of several GB)
set -eu

build=build/release
repeats=5
sizes="640x480x128 1242x375x128 1282x1110x256 3840x1728x128"
stream_pairs=20
hh=1
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build=$2; shift 2 ;;
    --repeats) repeats=$2; shift 2 ;;
    --sizes) sizes=$2; shift 2 ;;
    --stream-pairs) stream_pairs=$2; shift 2 ;;
    --no-hh) hh=0; shift ;;
    *) echo "oneshot-disparity.sh: unknown argument '$1' (see the header for the usage)" >&2; exit 2 ;;
  esac
done
lpstereo=$build/tools/lpstereo
opencv=$build/bench/opencv_disparity_oneshot
for program in "$lpstereo" "$opencv" /usr/bin/time; do
  [ -x "$program" ] || { echo "oneshot-disparity.sh: '$program' is missing (build the release preset; GNU time: apt install time)" >&2; exit 2; }
done
case "$repeats" in ''|*[!0-9]*|0) echo "oneshot-disparity.sh: --repeats: expected a positive integer, got '$repeats'" >&2; exit 2 ;; esac

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# median FILE COLUMN: the median of a column of numbers.
median() {
  sort -n -k"$2","$2" "$1" | awk -v column="$2" '{ value[NR] = $column } END { if (NR % 2) print value[(NR + 1) / 2]; else printf "%.3f\n", (value[NR / 2] + value[NR / 2 + 1]) / 2 }'
}

# timed NAME COMMAND...: one run, "wall_s peak_kb sys_s" appended to $work/NAME.times.
timed() {
  name=$1; shift
  if ! /usr/bin/time -f "%e %M %S" -o "$work/time.txt" "$@" > "$work/out.txt" 2>&1; then
    echo "oneshot-disparity.sh: '$*' failed:" >&2; cat "$work/out.txt" >&2; exit 1
  fi
  cat "$work/time.txt" >> "$work/$name.times"
}

echo "# One-shot disparity, whole process, 2 threads, medians of $repeats ($(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cores)"
/usr/bin/time -f "%M" -o "$work/start_lpstereo.txt" "$lpstereo" kernels > /dev/null
# The OpenCV program with no arguments: its usage error, so the libraries alone (exit 2 expected).
/usr/bin/time -f "%M" -o "$work/start_opencv.txt" "$opencv" 2> /dev/null || true
echo "start-up peak memory: lpstereo $(($(tail -n 1 "$work/start_lpstereo.txt") / 1024)) MB," \
  "opencv_disparity_oneshot $(($(tail -n 1 "$work/start_opencv.txt") / 1024)) MB (the libraries alone)"
echo
printf '%-16s %-34s %10s %10s %8s   %s\n' "case" "program" "wall s" "peak MB" "sys s" "ratio"
for size in $sizes; do
  width=${size%%x*}; rest=${size#*x}; height=${rest%%x*}; disparities=${rest#*x}
  pair=$work/pair_$size
  "$lpstereo" synth -o "$pair" --width "$width" --height "$height" --noise 2 > /dev/null
  rm -f "$work"/*.times
  names="lpstereo_8 lpstereo_4 opencv_sgbm opencv_3way"
  [ "$hh" = 1 ] && names="$names opencv_hh"
  [ "$width" -ge 3840 ] && names="$names lpstereo_multires"
  run=0
  while [ $run -lt "$repeats" ]; do
    for name in $names; do
      case $name in
        lpstereo_8) timed $name "$lpstereo" disparity "$pair/left.png" "$pair/right.png" -o "$work/d.png" --num-disp "$disparities" --threads 2 ;;
        lpstereo_4) timed $name "$lpstereo" disparity "$pair/left.png" "$pair/right.png" -o "$work/d.png" --num-disp "$disparities" --paths 4 --threads 2 ;;
        lpstereo_multires) timed $name "$lpstereo" disparity "$pair/left.png" "$pair/right.png" -o "$work/d.png" --num-disp 256 --multires on --paths 4 --threads 2 ;;
        opencv_sgbm) timed $name "$opencv" "$pair/left.png" "$pair/right.png" "$work/d.png" --num-disp "$disparities" --mode sgbm --threads 2 ;;
        opencv_3way) timed $name "$opencv" "$pair/left.png" "$pair/right.png" "$work/d.png" --num-disp "$disparities" --mode 3way --threads 2 ;;
        opencv_hh) timed $name "$opencv" "$pair/left.png" "$pair/right.png" "$work/d.png" --num-disp "$disparities" --mode hh --threads 2 ;;
      esac
    done
    run=$((run + 1))
  done
  for name in $names; do
    eval "wall_$name=$(median "$work/$name.times" 1)"
    eval "peak_$name=$(median "$work/$name.times" 2)"
    eval "sys_$name=$(median "$work/$name.times" 3)"
  done
  for name in $names; do
    case $name in
      lpstereo_8) label="lpstereo 8 paths"; against=opencv_hh; line="<= 0.25 x MODE_HH" ;;
      lpstereo_4) label="lpstereo 4 paths"; against=opencv_3way; line="<= 1 x MODE_SGBM_3WAY" ;;
      lpstereo_multires) label="lpstereo 4 paths multires x256"; against=opencv_3way; line="vs MODE_SGBM_3WAY x128" ;;
      opencv_sgbm) label="OpenCV MODE_SGBM"; against=""; line="" ;;
      opencv_3way) label="OpenCV MODE_SGBM_3WAY"; against=""; line="" ;;
      opencv_hh) label="OpenCV MODE_HH"; against=""; line="" ;;
    esac
    eval "wall=\$wall_$name; peak=\$peak_$name; sys=\$sys_$name"
    ratio=""
    if [ -n "$against" ] && echo " $names " | grep -q " $against "; then
      eval "base=\$wall_$against"
      ratio=$(awk -v a="$wall" -v b="$base" -v line="$line" 'BEGIN { printf "%.2f x (line %s)", a / b, line }')
    fi
    printf '%-16s %-34s %10s %10d %8s   %s\n' "${width}x${height}x$disparities" "$label" "$wall" "$((peak / 1024))" "$sys" "$ratio"
  done
done

# Streaming at 4K: the pair rendered above, replayed --stream-pairs times through `lpstereo run`
# (each run's default pairs in flight: 2 for 4 paths, 1 for 8, tools/disparity_lanes.h); then the
# same pair as PGM, whose decoding is a copy: the rate with PNG decoding excluded.
if [ "$stream_pairs" -gt 0 ] && [ -d "$work/pair_3840x1728x128" ]; then
  pair=$work/pair_3840x1728x128
  for view in left right; do "$opencv" --convert "$pair/$view.png" "$pair/$view.pgm"; done
  for extension in png pgm; do
    mkdir -p "$work/stream_$extension/left" "$work/stream_$extension/right"
    i=0
    while [ $i -lt "$stream_pairs" ]; do
      name=$(printf '%06d' $i)
      for view in left right; do ln -s "$pair/$view.$extension" "$work/stream_$extension/$view/$name.$extension"; done
      i=$((i + 1))
    done
  done
  stream() {  # extension paths
    /usr/bin/time -f "%e %M" -o "$work/time.txt" "$lpstereo" run \
      --source "files:$work/stream_$1/left/%06d.$1,$work/stream_$1/right/%06d.$1" \
      --calib "$pair/calib_cam_to_cam.txt" --target none --num-disp 128 --paths "$2" --threads 2 --status-every 1000000 > "$work/out.txt" 2>&1 || {
      echo "oneshot-disparity.sh: lpstereo run failed:" >&2; cat "$work/out.txt" >&2; exit 1; }
    tail -n 1 "$work/out.txt"
    echo "  $2 paths, $1 frames: $(awk '{ printf "%.2f s wall for the process, peak %d MB", $1, $2 / 1024 }' "$work/time.txt")"
  }
  echo
  echo "# Streaming 3840x1728 x 128, lpstereo run over $stream_pairs pairs, 2 threads, PNG decoding included (line: >= 4 pairs/s, 4 paths)"
  for paths in 4 8; do stream png "$paths"; done
  echo "# The same, PGM frames (PNG decoding excluded)"
  stream pgm 4
fi
