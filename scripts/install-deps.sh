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
  # sources (vimc is built out of tree from them; linux-source-<series> at the image's version, below),
  # qemu to boot it, busybox for the initramfs
  linux-image-amd64 linux-headers-amd64 qemu-system-x86 busybox-static cpio kmod
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

# The vimc module is built from linux-source of exactly the kernel image's Debian version
# (tests/vm/build-vimc-module.sh). The two meta-packages move independently in the registry (seen:
# image 6.1.192-2 beside source 6.1.192-3), so the source is pinned to the image's version here.
matching_kernel_source() {
  local image_package image_version series
  image_package=$(dpkg-query -W -f='${Depends}' linux-image-amd64 2>/dev/null | grep -o 'linux-image-[0-9][^ ,]*' | head -n 1)
  [ -n "$image_package" ] || return 0
  image_version=$(dpkg-query -W -f='${Version}' "$image_package" 2>/dev/null) || return 0
  series=$(echo "$image_version" | cut -d. -f1-2)
  if [ "$(dpkg-query -W -f='${Version}' "linux-source-$series" 2>/dev/null)" != "$image_version" ]; then
    echo "linux-source-$series=$image_version"
  fi
}

if [ "${#missing[@]}" -eq 0 ] && [ -z "$(matching_kernel_source)" ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

if [ "$(id -u)" -ne 0 ]; then
  echo "install-deps: missing packages (${missing[*]} $(matching_kernel_source)) and not root; run as root" >&2
  exit 1
fi

export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
if [ "${#missing[@]}" -gt 0 ]; then
  echo "install-deps: installing ${missing[*]}"
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
kernel_source=$(matching_kernel_source)
if [ -n "$kernel_source" ]; then
  echo "install-deps: installing $kernel_source (the kernel image's version, for the vimc module)"
  # A registry without that version leaves the newer source: the vimc test then names the mismatch.
  apt-get install -y -qq --no-install-recommends --allow-downgrades "$kernel_source" >/dev/null ||
    echo "install-deps: $kernel_source is not in the registry; the vimc test will say so" >&2
fi
echo "install-deps: done"
