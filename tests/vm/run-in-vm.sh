#!/usr/bin/env bash
# Boots Debian's kernel under qemu-system-x86_64 (software emulation: -accel tcg -cpu max; KVM is
# not usable on these machines) with a small initramfs of busybox-static, the kernel modules asked
# for (and their dependencies, resolved by depmod), extra out-of-tree modules and files, and runs
# one program in it. The program's output is the VM's console; this script prints it, and exits
# with the program's exit code (124 when the VM did not finish within --timeout seconds).
#
#   run-in-vm.sh --work DIR [--module NAME[:ARGS]]... [--extra-module FILE.ko[:ARGS]]...
#                [--file SRC=DEST]... [--libraries-of FILE]... [--host-root] [--timeout S]
#                [--memory-mb N] -- PROGRAM [ARGS...]
#
#   --module NAME[:ARGS]      a module of the installed kernel, loaded with modprobe in the order
#                             given (ARGS: its parameters, space separated, e.g. "vivid:n_devs=2")
#   --extra-module F[:ARGS]   an out-of-tree module built for that kernel (e.g. vimc.ko), installed
#                             under /lib/modules/VERSION/extra and loaded after the --module ones
#   --file SRC=DEST           a file copied into the VM at DEST (absolute)
#   --libraries-of FILE       the shared libraries FILE needs (ldd), and the dynamic loader, copied
#                             to the same paths (for dynamically linked programs and plugins)
#   --host-root               the host's file system at /host in the VM, so a dynamically linked
#                             program of the host runs there unchanged with `chroot /host`: the
#                             host's root read-only over virtio 9p under an overlay whose upper
#                             layer is a tmpfs (writes stay in the VM; the host's files, its /tmp
#                             included, are all visible), with the VM's /dev, /proc and /sys
#   PROGRAM                   copied to /test/PROGRAM's basename and run from /test; statically
#                             linked, or use --libraries-of PROGRAM
#
# The kernel is the newest /boot/vmlinuz-VERSION with a matching /lib/modules/VERSION (Debian's
# linux-image-amd64, installed by scripts/install-deps.sh). Exit 125: a tool or the kernel missing.
set -euo pipefail

die() { echo "run-in-vm: $*" >&2; exit 125; }

work="" timeout_s=120 memory_mb=768
modules=() extra_modules=() files=() library_owners=() host_root=0
while [ $# -gt 0 ]; do
  case "$1" in
    --work) work="$2"; shift 2 ;;
    --module) modules+=("$2"); shift 2 ;;
    --extra-module) extra_modules+=("$2"); shift 2 ;;
    --file) files+=("$2"); shift 2 ;;
    --libraries-of) library_owners+=("$2"); shift 2 ;;
    --host-root) host_root=1; shift ;;
    --timeout) timeout_s="$2"; shift 2 ;;
    --memory-mb) memory_mb="$2"; shift 2 ;;
    --) shift; break ;;
    *) die "unknown option '$1' (see the header of $0)" ;;
  esac
done
[ $# -ge 1 ] || die "no program given after --"
[ -n "$work" ] || die "--work DIR is required"
program="$1"; shift
[ -x "$program" ] || die "program '$program': not an executable file"

command -v qemu-system-x86_64 >/dev/null || die "qemu-system-x86_64 not installed (package qemu-system-x86)"
[ -x /bin/busybox ] && file -L /bin/busybox | grep -q "statically linked" || die "/bin/busybox is not busybox-static"
command -v depmod >/dev/null || command -v /sbin/depmod >/dev/null || die "depmod not installed (package kmod)"
source "$(dirname "$0")/installed-kernel.sh"
[ -n "$kernel_version" ] || die "no /boot/vmlinuz-VERSION with /lib/modules/VERSION (package linux-image-amd64)"

root="$work/root"
rm -rf "$root"
mkdir -p "$root"/{bin,sbin,proc,sys,dev,tmp,test,etc} "$root/lib/modules/$kernel_version"
cp /bin/busybox "$root/bin/busybox"

# The asked-for modules with everything they depend on (modinfo's depends, recursively), at their
# paths under kernel/, then depmod for busybox's modprobe.
module_source="/lib/modules/$kernel_version"
declare -A copied=()
copy_module() {
  local name="$1" path depends dependency
  [ -n "${copied[$name]:-}" ] && return 0
  path=$(/sbin/modinfo -k "$kernel_version" -n "$name" 2>/dev/null) || die "module '$name' not found for kernel $kernel_version"
  copied[$name]=1
  case "$path" in (builtin*|"") return 0 ;; esac
  mkdir -p "$root/$(dirname "$path")"
  cp "$path" "$root/$path"
  depends=$(/sbin/modinfo -k "$kernel_version" -F depends "$name")
  for dependency in ${depends//,/ }; do copy_module "$dependency"; done
}
load_lines=()
qemu_extra=()
if [ "$host_root" = 1 ]; then
  # virtio-pci is no dependency of 9pnet_virtio (the bus driver is found by the device), so it is named.
  modules=("virtio_pci" "9pnet_virtio" "9p" "overlay" "${modules[@]}")
  qemu_extra=(-virtfs "local,path=/,mount_tag=hostroot,security_model=none,readonly=on,multidevs=remap")
fi
for entry in "${modules[@]}"; do
  name="${entry%%:*}"; arguments=""; [ "$entry" != "$name" ] && arguments="${entry#*:}"
  copy_module "$name"
  load_lines+=("modprobe $name $arguments || { echo 'VM: modprobe $name failed'; fail=1; }")
done
for entry in "${extra_modules[@]}"; do
  file="${entry%%:*}"; arguments=""; [ "$entry" != "$file" ] && arguments="${entry#*:}"
  [ -f "$file" ] || die "extra module '$file': no such file"
  mkdir -p "$root/$module_source/extra"
  cp "$file" "$root/$module_source/extra/"
  name=$(basename "$file" .ko)
  for dependency in $(/sbin/modinfo -F depends "$file" | tr ',' ' '); do copy_module "$dependency"; done
  load_lines+=("modprobe $name $arguments || { echo 'VM: modprobe $name failed'; fail=1; }")
done
cp "$module_source"/modules.{order,builtin,builtin.modinfo} "$root/$module_source/" 2>/dev/null || true
/sbin/depmod -b "$root" "$kernel_version"

for entry in "${files[@]}"; do
  source="${entry%%=*}"; destination="${entry#*=}"
  [ -e "$source" ] || die "file '$source': no such file"
  mkdir -p "$root/$(dirname "$destination")"
  cp -r "$source" "$root/$destination"
done
copy_libraries() {
  local owner="$1" library
  for library in $(ldd "$owner" 2>/dev/null | grep -o '/[^ ]*' | sort -u); do
    [ -e "$root/$library" ] && continue
    mkdir -p "$root/$(dirname "$library")"
    cp -L "$library" "$root/$library"
  done
}
for owner in "${library_owners[@]}"; do copy_libraries "$owner"; done
cp "$program" "$root/test/"
program_name=$(basename "$program")

quoted_arguments=""
for argument in "$@"; do quoted_arguments+=" '${argument//\'/\'\\\'\'}'"; done
{
  echo '#!/bin/busybox sh'
  echo '/bin/busybox --install -s /bin'
  echo 'mount -t proc proc /proc; mount -t sysfs sysfs /sys; mount -t devtmpfs devtmpfs /dev; mount -t tmpfs tmpfs /tmp'
  echo 'fail=0'
  echo "echo \"VM: kernel \$(uname -r), $(( ${#modules[@]} + ${#extra_modules[@]} )) modules to load\""
  printf '%s\n' "${load_lines[@]}"
  if [ "$host_root" = 1 ]; then
    echo 'mkdir -p /host /host-9p /host-writes'
    echo 'mount -t 9p -o trans=virtio,version=9p2000.L,ro,msize=262144,cache=loose hostroot /host-9p || { echo "VM: mounting the host root failed"; fail=1; }'
    echo 'mount -t tmpfs tmpfs /host-writes && mkdir -p /host-writes/upper /host-writes/work'
    echo 'mount -t overlay overlay -o lowerdir=/host-9p,upperdir=/host-writes/upper,workdir=/host-writes/work /host || { echo "VM: the overlay on the host root failed"; fail=1; }'
    echo 'mount -o bind /dev /host/dev && mount -t proc proc /host/proc && mount -t sysfs sysfs /host/sys || { echo "VM: mounts in /host failed"; fail=1; }'
  fi
  echo 'cd /test'
  echo 'if [ "$fail" = 0 ]; then'
  echo "  ./$program_name$quoted_arguments"
  echo '  code=$?'
  echo 'else code=125; fi'
  echo 'echo "VM-EXIT-CODE=$code"'
  echo 'sync; poweroff -f'
} > "$root/init"
chmod +x "$root/init"

(cd "$root" && find . | cpio -o -H newc --quiet | gzip -1) > "$work/initramfs.gz"
log="$work/console.log"
status=0
timeout "$timeout_s" qemu-system-x86_64 -accel tcg -cpu max -smp 1 -m "$memory_mb" -nographic -no-reboot \
  -kernel "/boot/vmlinuz-$kernel_version" -initrd "$work/initramfs.gz" \
  -append "console=ttyS0 quiet loglevel=3 panic=-1" "${qemu_extra[@]}" </dev/null >"$log" 2>&1 || status=$?
# The console with the terminal control sequences of the firmware taken out.
sed -e 's/\x1b\[[0-9;?]*[A-Za-z]//g' -e 's/\x1bc//g' -e 's/\r$//' "$log"
if [ "$status" -eq 124 ]; then
  echo "run-in-vm: the VM did not finish within $timeout_s s" >&2
  exit 124
fi
code=$(sed -n 's/.*VM-EXIT-CODE=\([0-9]*\).*/\1/p' "$log" | tail -1)
[ -n "$code" ] || { echo "run-in-vm: the VM stopped without the program's exit code (qemu status $status)" >&2; exit 1; }
exit "$code"
