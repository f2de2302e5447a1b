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

# libcamera on vimc (issue 7, deliverable 4): the vimc module is built from Debian's linux-source
# by the test's wrapper (tests/vm/vimc_libcamera.sh) into the build tree; the test program carries
# its shared libraries into the VM.
if(LPSTEREO_VM_AVAILABLE AND TARGET lpstereo_libcamera)
  file(GLOB lpstereo_linux_sources /usr/src/linux-source-*.tar.xz)
  if(NOT lpstereo_linux_sources)
    message(STATUS "VM test vimc_libcamera: not registered, no /usr/src/linux-source-*.tar.xz (linux-source, scripts/install-deps.sh)")
  elseif(NOT EXISTS /lib/systemd/systemd-udevd)
    message(STATUS "VM test vimc_libcamera: not registered, /lib/systemd/systemd-udevd missing (package udev)")
  else()
    add_executable(vimc_libcamera_test ${LPSTEREO_VM_DIR}/vimc_libcamera_test.cpp)
    target_include_directories(vimc_libcamera_test PRIVATE ${PROJECT_SOURCE_DIR})
    target_link_libraries(vimc_libcamera_test PRIVATE lpstereo::libcamera)
    lpstereo_warnings(vimc_libcamera_test)
    add_test(NAME Vm.vimc_libcamera
             COMMAND ${LPSTEREO_VM_DIR}/vimc_libcamera.sh ${LPSTEREO_VM_WORK_DIR}/vimc_libcamera
                     $<TARGET_FILE:vimc_libcamera_test>)
    set_tests_properties(Vm.vimc_libcamera PROPERTIES TIMEOUT 240)
  endif()
endif()
