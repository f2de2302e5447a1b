#!/usr/bin/env bash
# Vm.vimc_libcamera: builds vimc.ko (tests/vm/build-vimc-module.sh, kept between runs), then boots
# Debian's kernel with it (tests/vm/run-in-vm.sh) and runs tests/vm/vimc_libcamera_test.cpp there
# with what libcamera needs at run time, at the paths Debian installs them:
#   - the vimc IPA module, its signature (a signed module runs in the process; without the .sign
#     libcamera would isolate it in the proxy), the IPA proxy and the IPA's configuration file;
#   - systemd-udevd and udevadm: libcamera's enumerator lists only devices udev has initialised and
#     hears of removed ones through udevd's monitor.
#
#   vimc_libcamera.sh WORK_DIR TEST_PROGRAM
set -euo pipefail
work="${1:?usage: vimc_libcamera.sh WORK_DIR TEST_PROGRAM}"
program="${2:?usage: vimc_libcamera.sh WORK_DIR TEST_PROGRAM}"
here=$(cd "$(dirname "$0")" && pwd)
ipa_dir=$(pkg-config --variable=libdir libcamera 2>/dev/null || echo /usr/lib/x86_64-linux-gnu)/libcamera
ipa_data=/usr/share/libcamera/ipa/vimc/vimc.conf
udevd=/lib/systemd/systemd-udevd

for needed in "$ipa_dir/ipa_vimc.so" "$ipa_dir/ipa_vimc.so.sign" "$ipa_dir/vimc_ipa_proxy" "$ipa_data" "$udevd"; do
  [ -e "$needed" ] || { echo "vimc_libcamera: $needed missing (packages libcamera-ipa, udev)" >&2; exit 125; }
done
udevadm=$(readlink -f "$udevd")   # Debian's systemd-udevd is a link to udevadm

mkdir -p "$work"
"$here/build-vimc-module.sh" "$work/vimc"
files=()
for file in "$ipa_dir/ipa_vimc.so" "$ipa_dir/ipa_vimc.so.sign" "$ipa_dir/vimc_ipa_proxy" "$ipa_data"; do
  files+=(--file "$file=$file")
done
exec "$here/run-in-vm.sh" --work "$work/vm" --timeout 170 --extra-module "$work/vimc/vimc.ko" \
  "${files[@]}" --file "$udevadm=$udevd" --file "$udevadm=/bin/udevadm" \
  --libraries-of "$program" --libraries-of "$ipa_dir/ipa_vimc.so" --libraries-of "$ipa_dir/vimc_ipa_proxy" \
  --libraries-of "$udevadm" \
  -- "$program"
