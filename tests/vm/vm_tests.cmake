# Tests against real kernel drivers: Debian's kernel booted under qemu-system-x86_64 (software
# emulation) with the vivid and vimc virtual camera drivers, a busybox initramfs and a test program
# (tests/vm/run-in-vm.sh, tests/vm/build-vimc-module.sh). Registered when the host has what
# scripts/install-deps.sh installs (qemu-system-x86, busybox-static, linux-image-amd64 and for vimc
# linux-headers-amd64 and linux-source); otherwise CMake says which tool is missing. The host build
# only: the programs are linked statically (vivid) or carry their libraries into the VM (libcamera),
# neither of which a sanitizer build can do, and one run per CI is enough.
find_program(LPSTEREO_QEMU_SYSTEM_X86_64 qemu-system-x86_64)
file(GLOB lpstereo_vm_kernels /boot/vmlinuz-*)
set(LPSTEREO_VM_AVAILABLE OFF)
if(NOT LPSTEREO_QEMU_SYSTEM_X86_64)
  message(STATUS "VM tests (vivid, vimc): not registered, qemu-system-x86_64 missing (scripts/install-deps.sh)")
elseif(NOT EXISTS /bin/busybox)
  message(STATUS "VM tests (vivid, vimc): not registered, busybox-static missing (scripts/install-deps.sh)")
elseif(NOT lpstereo_vm_kernels)
  message(STATUS "VM tests (vivid, vimc): not registered, no kernel in /boot (linux-image-amd64, scripts/install-deps.sh)")
else()
  set(LPSTEREO_VM_AVAILABLE ON)
  message(STATUS "VM tests (vivid, vimc): registered")
endif()
set(LPSTEREO_VM_DIR ${PROJECT_SOURCE_DIR}/tests/vm)
set(LPSTEREO_VM_WORK_DIR ${CMAKE_CURRENT_BINARY_DIR}/vm-work)
