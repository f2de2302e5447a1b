#!/usr/bin/env bash
# Assembles the arm64 sysroot the aarch64 cross build compiles, links and runs against (the
# toolchain file cmake/aarch64-linux-gnu.cmake calls this at configure time; scripts/check.sh
# through it). Debian's arm64 packages of the build machine's own release (its apt sources, so the
# same OpenCV, libpng and zlib as the x86 build, whose output the qemu run must equal bit for bit)
# are downloaded with a private apt state and unpacked with dpkg-deb: the build machine's dpkg
# database and architecture list are left alone, and root is not needed.
#
# Only what the lpstereo command links is taken:
#   - RUNTIME: the shared libraries, with their whole Depends closure (the target's dynamic linker
#     loads all of it, and the cross linker follows their DT_NEEDED entries);
#   - HEADERS: the -dev packages of those libraries, without their Depends: libopencv-*-dev would
#     otherwise bring the -dev packages of FFmpeg, GDAL, GStreamer and Qt (1.1 GB instead of ~0.3);
#     and the header-only CLI11 of the command line. (Eigen and nlohmann JSON, also header-only, are
#     taken from the build machine by cmake/cross.cmake, as before the sysroot existed.)
# OpenCV's video I/O (FFmpeg, GStreamer) is not taken: the native build links it only into the
# video decoder module that is loaded when a video is opened (io/camera/video_decoder.h), and the
# cross build leaves that module out.
#
# The C library: the cross compiler always searches its own /usr/aarch64-linux-gnu (Debian's
# libc6-dev-arm64-cross) before the sysroot, so the C and C++ library headers and link-time stubs
# are the cross toolchain's, and the sysroot holds no libc6-dev (a second copy of the headers would
# only be shadowed). At run time qemu-aarch64 -L loads the sysroot's libc6 and libstdc++6, as the
# board would. Both are built from the same Debian release's glibc 2.36 and GCC 12 sources (a
# stable release's updates add no symbol versions), so what the linker binds, the loader provides.
#
# Usage: make-arm64-sysroot.sh [DIR]   (default: build/arm64-sysroot in the source tree)
# Idempotent: a sysroot whose stamp names this package list is left as it is (a second or so).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
sysroot=${1:-$here/build/arm64-sysroot}

runtime=(
  libc6 libgcc-s1 libstdc++6
  libopencv-core406 libopencv-imgproc406 libopencv-imgcodecs406 libopencv-calib3d406 libopencv-features2d406
  libcamera0.0.3
)
headers=(
  libopencv-core-dev libopencv-imgproc-dev libopencv-imgcodecs-dev libopencv-calib3d-dev
  libopencv-features2d-dev libopencv-flann-dev
  libcamera-dev
  libpng-dev zlib1g-dev
  libcli11-dev
)
# Downloaded as dependencies but not unpacked: Mesa's OpenGL drivers (libglvnd, which GDAL's
# closure links, loads them with dlopen; nothing lpstereo runs draws) and the LLVM and Z3 they bring:
# 150 MB of the 450 unpacked.
not_unpacked=(libgl1-mesa-dri libglx-mesa0 libllvm15 libz3-4)
# The stamp changes with the package list, the apt sources (the release) and this script's layout
# version, so editing any of them reassembles the sysroot.
layout=4
sources=$(cat /etc/apt/sources.list /etc/apt/sources.list.d/*.list /etc/apt/sources.list.d/*.sources 2>/dev/null || true)
stamp_text=$(printf 'layout %s\nruntime %s\nheaders %s\nnot unpacked %s\nsources %s\n' "$layout" "${runtime[*]}" \
  "${headers[*]}" "${not_unpacked[*]}" \
  "$(echo "$sources" | sha256sum | cut -d' ' -f1)")
stamp=$sysroot/.lpstereo-arm64-sysroot
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$stamp_text" ]; then
  exit 0
fi

for tool in apt-get dpkg-deb; do
  command -v "$tool" >/dev/null || { echo "make-arm64-sysroot: $tool not found (the sysroot is assembled from Debian packages with apt)" >&2; exit 1; }
done

start=$SECONDS
work=$sysroot.work
rm -rf "$sysroot" "$work"
mkdir -p "$work/state/lists/partial" "$work/cache/archives/partial" "$sysroot"
: >"$work/status"
log=$work/apt.log
# A private apt: arm64 only, an empty dpkg status (so the whole closure is downloaded, none of it is
# taken as already installed), its own lists and cache; downloads run as the calling user.
apt_options=(
  -o APT::Architecture=arm64 -o APT::Architectures=arm64
  -o Dir::State="$work/state" -o Dir::State::status="$work/status" -o Dir::Cache="$work/cache"
  -o Debug::NoLocking=1 -o APT::Sandbox::User="$(id -un)"
  -o APT::Install-Recommends=false -o APT::Install-Suggests=false -q
)
fail() {
  echo "make-arm64-sysroot: $1 failed (apt-get exit $2; Debian's arm64 registry unreachable or a package missing); apt's log: $log" >&2
  exit 1
}
echo "make-arm64-sysroot: downloading Debian's arm64 packages into $sysroot"
apt-get "${apt_options[@]}" update --error-on=any >"$log" 2>&1 || fail "apt-get update of the arm64 package lists" $?
apt-get "${apt_options[@]}" install --download-only -y "${runtime[@]}" >>"$log" 2>&1 ||
  fail "downloading the runtime libraries (${runtime[*]}) with their dependencies" $?
(cd "$work/cache/archives" && apt-get "${apt_options[@]}" download "${headers[@]}" >>"$log" 2>&1) ||
  fail "downloading the headers (${headers[*]})" $?

debs=("$work"/cache/archives/*.deb)
for deb in "${debs[@]}"; do
  package=$(basename "$deb")
  package=${package%%_*}
  if [[ " ${not_unpacked[*]} " != *" $package "* ]]; then
    dpkg-deb -x "$deb" "$sysroot"
  fi
done
# Debian selects the BLAS and LAPACK implementation with update-alternatives when a package is
# configured; unpacking configures nothing, so the links libopencv_core's DT_NEEDED entries name
# (libblas.so.3, liblapack.so.3) are made here, to the reference implementations apt chose.
for name in blas lapack; do
  ln -sfn "$name/lib$name.so.3" "$sysroot/usr/lib/aarch64-linux-gnu/lib$name.so.3"
done
# Documentation, manual pages and translations: not used by a compiler or a program run under qemu.
rm -rf "$sysroot/usr/share/doc" "$sysroot/usr/share/man" "$sysroot/usr/share/locale" "$sysroot/usr/share/info"
# Debian's packages hold absolute symbolic links (usr/lib/aarch64-linux-gnu/libfoo.so -> /lib/...):
# resolved on the build machine they would name its own x86-64 files, so they are made relative.
while IFS= read -r -d '' link; do
  target=$(readlink "$link")
  ln -sfn "$(realpath -m --relative-to="$(dirname "$link")" "$sysroot$target")" "$link"
done < <(find "$sysroot" -type l -lname '/*' -print0)

download_bytes=$(du -cb "${debs[@]}" | tail -n 1 | cut -f1)
rm -rf "$work"
echo "$stamp_text" >"$stamp"
echo "make-arm64-sysroot: ${#debs[@]} packages ($((download_bytes / 1000000)) MB downloaded), $(du -sh "$sysroot" | cut -f1) unpacked, in $((SECONDS - start)) s"
