# Sourced by the VM scripts: sets kernel_version to the newest /boot/vmlinuz-VERSION that has its
# modules in /lib/modules/VERSION (Debian's linux-image-amd64), or to "" when there is none.
kernel_version=""
for image in $(ls -1 /boot/vmlinuz-* 2>/dev/null | sort -V -r); do
  version="${image#/boot/vmlinuz-}"
  if [ -d "/lib/modules/$version/kernel" ]; then kernel_version="$version"; break; fi
done
