#!/usr/bin/env bash
# Installs every Debian package lpstereo needs to build, test, benchmark and cross-build.
# Idempotent; run as root on Debian 12 (bookworm). Uses only Debian's package registry.
set -euo pipefail

packages=(
  # build
  build-essential cmake ninja-build pkg-config git ccache
  # libraries: linear algebra, JSON, command line, codecs and reference algorithms
  libeigen3-dev nlohmann-json3-dev libcli11-dev libopencv-dev libpng-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev python3
  # aarch64 cross-build, and user-mode emulation to run the cross-built tests
  # (qemu-x86_64 also runs the host build on a CPU model without AVX-512)
  g++-aarch64-linux-gnu qemu-user
  # cameras: V4L2 headers and libv4l, libcamera with its IPA modules (the vimc pipeline needs ipa_vimc)
  libv4l-dev libcamera-dev libcamera-ipa
  # the real-driver tests (tests/vm): Debian's kernel (ships the vivid module), its headers and
  # sources (vimc is built out of tree from them), qemu to boot it, busybox for the initramfs
  linux-image-amd64 linux-headers-amd64 linux-source qemu-system-x86 busybox-static cpio kmod
  # v4l2-ctl presses vivid's controls while `lpstereo run` runs in the VM
  v4l-utils
  # libcamera lists only devices udev has initialised: the vimc test runs systemd-udevd in the VM
  udev
)

missing=()
for package in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$package")
  fi
done

if [ "${#missing[@]}" -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

if [ "$(id -u)" -ne 0 ]; then
  echo "install-deps: missing packages (${missing[*]}) and not root; run as root" >&2
  exit 1
fi

echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
