#!/bin/sh
# Runs inside the VM (tests/vm/run-in-vm.sh --host-root, busybox sh): the host's own `lpstereo run`
# (dynamically linked, started with chroot /host) on two vivid capture devices, the way a user
# brings up a stereo pair of V4L2 cameras:
#   1. a live run of N pairs with --record and --out: exit 0, N disparity maps, every delivered
#      pair recorded (also those processing skipped), and the recording replays through files:;
#   2. a stalled camera (vivid drops 100 % of its buffers): exit 1 after --timeout-ms, one line;
#   3. an output node given as a view: exit 1, one line;
#   4. the right camera unplugged mid-run (vivid's Disconnect control, pressed by v4l2-ctl while
#      lpstereo runs): exit 1 with one line naming the device, every recorded pair complete
#      (both views of each, readable: the recording replays).
# Usage: vivid_lpstereo_run.sh LPSTEREO (the binary's path on the host)
lpstereo="$1"
failures=0
check() {  # check DESCRIPTION CONDITION...
  description="$1"; shift
  if "$@"; then echo "  ok: $description"; else echo "  FAILED: $description"; failures=$((failures + 1)); fi
}
in_host() { chroot /host "$@"; }
node_of() {  # the /dev/videoN whose sysfs name is $1
  for node in /sys/class/video4linux/video*; do
    [ "$(cat "$node/name")" = "$1" ] && { echo "/dev/$(basename "$node")"; return; }
  done
}
left=$(node_of vivid-000-vid-cap); right=$(node_of vivid-001-vid-cap); output=$(node_of vivid-000-vid-out)
echo "vivid nodes: left $left, right $right, an output $output"
# Everything the runs write goes to a fresh folder (the host's /tmp is visible through the overlay;
# the writes stay in the VM).
run_dir=$(chroot /host mktemp -d /tmp/lpstereo-vivid-run.XXXXXX) || { echo "mktemp in /host failed"; exit 1; }
echo "writing to $run_dir (in the VM's overlay)"
# A rectified 320x180 pair (Middlebury calib.txt: already rectified views).
printf 'cam0=[300 0 159.5; 0 300 89.5; 0 0 1]\ncam1=[300 0 159.5; 0 300 89.5; 0 0 1]\ndoffs=0\nbaseline=120\nwidth=320\nheight=180\nndisp=32\n' \
  > /host$run_dir/calib.txt
common="--source v4l2:$left,$right --calib $run_dir/calib.txt --width 320 --height 180 --pixel-format YUYV --fps 30 --num-disp 32 --threads 1"
lines_of() { grep -c '' "$1"; }
count_png() { ls "$1" 2>/dev/null | grep -c '\.png$'; }
replays() {  # replays DIR PAIRS: the recording in DIR (a path in /host) replays through files:, every pair
  in_host "$lpstereo" run --source "files:$1/left/%06d.png,$1/right/%06d.png" --calib $run_dir/calib.txt \
    --num-disp 32 --threads 1 --target none >/tmp/replay.out 2>/tmp/replay.err
  replay_status=$?
  check "the recording replays (exit $replay_status)" [ "$replay_status" = 0 ]
  check "the replay processed all $2 recorded pairs" grep -q "run: $2 pairs processed" /tmp/replay.out
}

echo "== 1. live run: 12 pairs, recorded"
in_host "$lpstereo" run $common --frames 12 --record $run_dir/rec1 --out $run_dir/out1 --pairing-tolerance-ms 20 \
  >/tmp/run1.out 2>/tmp/run1.err
status=$?
cat /tmp/run1.err /tmp/run1.out | tr '\r' '\n' | grep -v '^$' | tail -6
check "exit 0 (got $status)" [ "$status" = 0 ]
check "the source pairs within the requested 20 ms" grep -q "paired within 20000 us" /tmp/run1.out
check "12 disparity maps written" [ "$(count_png /host$run_dir/out1/disparity)" = 12 ]
# The recording keeps every pair the cameras delivered, also those processing skipped.
recorded=$(count_png /host$run_dir/rec1/left)
check "as many left as right views recorded, at least 12 ($recorded, $(count_png /host$run_dir/rec1/right))" \
  [ "$recorded" = "$(count_png /host$run_dir/rec1/right)" -a "$recorded" -ge 12 ]
replays $run_dir/rec1 "$recorded"

echo "== 2. a stalled camera"
in_host v4l2-ctl -d "$left" --set-ctrl=percentage_of_dropped_buffers=100
in_host "$lpstereo" run --source v4l2:$left,$right --calib $run_dir/calib.txt --width 320 --height 180 \
  --num-disp 32 --threads 1 --timeout-ms 3000 >/tmp/run3.out 2>/tmp/run3.err </dev/null
status=$?
echo "  stderr: $(tail -1 /tmp/run3.err)"
check "exit 1 (got $status)" [ "$status" = 1 ]
in_host v4l2-ctl -d "$left" --set-ctrl=percentage_of_dropped_buffers=0

echo "== 3. an output node as a view"
in_host "$lpstereo" run --source v4l2:$left,$output --calib $run_dir/calib.txt >/tmp/run4.out 2>/tmp/run4.err
status=$?
echo "  stderr: $(cat /tmp/run4.err)"
check "exit 1 (got $status)" [ "$status" = 1 ]
check "one line" [ "$(lines_of /tmp/run4.err)" = 1 ]
check "it names the node" grep -q "$output" /tmp/run4.err

echo "== 4. the right camera unplugged mid-run (last: vivid removes the device)"
in_host "$lpstereo" run $common --record $run_dir/rec2 --timeout-ms 20000 >/tmp/run2.out 2>/tmp/run2.err &
run_pid=$!
# Wait for some recorded pairs, then pull the plug.
waited=0
while [ "$(count_png /host$run_dir/rec2/right)" -lt 5 ] && [ "$waited" -lt 120 ]; do sleep 1; waited=$((waited + 1)); done
echo "  $(count_png /host$run_dir/rec2/right) pairs recorded after ${waited} s; pressing vivid's Disconnect on $right"
in_host v4l2-ctl -d "$right" --set-ctrl=disconnect=1
waited=0
while kill -0 "$run_pid" 2>/dev/null && [ "$waited" -lt 60 ]; do sleep 1; waited=$((waited + 1)); done
if kill -0 "$run_pid" 2>/dev/null; then
  check "lpstereo run ended within 60 s of the disconnect" false
  kill -9 "$run_pid"
fi
wait "$run_pid"; status=$?
echo "  stderr:"; tr '\r' '\n' < /tmp/run2.err | grep -v '^$' | tail -3 | sed 's/^/    /'
check "exit 1 (got $status)" [ "$status" = 1 ]
check "stderr names the device and the disconnect" grep -q "$right.*disconnected" /tmp/run2.err
recorded_left=$(count_png /host$run_dir/rec2/left); recorded_right=$(count_png /host$run_dir/rec2/right)
check "as many left as right views recorded ($recorded_left, $recorded_right)" [ "$recorded_left" = "$recorded_right" -a "$recorded_left" -ge 5 ]
check "a timestamp line per recorded pair" [ "$(lines_of /host$run_dir/rec2/timestamps.txt)" -ge "$recorded_left" ]
replays $run_dir/rec2 "$recorded_left"  # every recorded pair complete and readable

echo "vivid_lpstereo_run: $failures failed checks"
[ "$failures" = 0 ]
