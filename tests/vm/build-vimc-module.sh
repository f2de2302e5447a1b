#!/usr/bin/env bash
# Builds the vimc virtual media-controller camera (libcamera's reference virtual camera) as an
# out-of-tree module for the installed Debian kernel: Debian's kernel config leaves
# CONFIG_VIDEO_VIMC unset, but everything vimc needs (media controller, the V4L2 subdevice API,
# v4l2-tpg, videobuf2) is built as modules, so the driver's sources from Debian's linux-source
# package compile against the matching linux-headers package.
#
#   build-vimc-module.sh OUTPUT_DIR      writes OUTPUT_DIR/vimc.ko (kept when already built for
#                                        this kernel)
# Exit 125: the kernel, its headers or the matching linux-source tarball are not installed.
set -euo pipefail
die() { echo "build-vimc-module: $*" >&2; exit 125; }

output="${1:?usage: build-vimc-module.sh OUTPUT_DIR}"
source "$(dirname "$0")/installed-kernel.sh"
[ -n "$kernel_version" ] || die "no installed kernel (package linux-image-amd64)"
headers="/usr/src/linux-headers-$kernel_version"
[ -f "$headers/Makefile" ] || die "no headers for kernel $kernel_version at $headers (package linux-headers-amd64)"

# The source tarball of the same Debian version as the kernel image.
image_package=$(dpkg-query -S "/boot/vmlinuz-$kernel_version" | cut -d: -f1)
image_version=$(dpkg-query -W -f='${Version}' "$image_package")
tarball=""
for candidate in /usr/src/linux-source-*.tar.xz; do
  [ -f "$candidate" ] || continue
  package=$(dpkg-query -S "$candidate" | cut -d: -f1)
  if [ "$(dpkg-query -W -f='${Version}' "$package")" = "$image_version" ]; then tarball="$candidate"; fi
done
[ -n "$tarball" ] || die "no /usr/src/linux-source-*.tar.xz of version $image_version (the kernel's; package linux-source)"

mkdir -p "$output"
stamp="$output/vimc.kernel"
if [ -f "$output/vimc.ko" ] && [ "$(cat "$stamp" 2>/dev/null)" = "$kernel_version $image_version" ]; then
  echo "build-vimc-module: $output/vimc.ko already built for $kernel_version"
  exit 0
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
top=$(basename "$tarball" .tar.xz)
tar -xJf "$tarball" -C "$work" --wildcards "$top/drivers/media/test-drivers/vimc/*"
source_dir="$work/$top/drivers/media/test-drivers/vimc"
make -s -C "$headers" M="$source_dir" CONFIG_VIDEO_VIMC=m modules >"$work/build.log" 2>&1 ||
  { cat "$work/build.log" >&2; echo "build-vimc-module: building vimc against $headers failed" >&2; exit 1; }
cp "$source_dir/vimc.ko" "$output/vimc.ko"
echo "$kernel_version $image_version" > "$stamp"
echo "build-vimc-module: built $output/vimc.ko for $kernel_version ($image_version) from $tarball"
