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

# Vm.vivid_capture: the V4L2 capture path against vivid (tests/vm/vivid_capture_test.cpp: two
# capture devices in GREY, YUYV, UYVY and NV12, side by side, the output-to-capture loopback of a
# known pair with its disparity, and a disconnect while streaming). The program is linked
# statically (the VM holds busybox and nothing else), with Debian's static libpng and zlib for the
# pair's PNG files. Its data come from the host's lpstereo in the build: a 640x480 synthetic pair
# (`lpstereo synth`, the size of the smallest HDMI timings vivid loops) and its disparity
# (`lpstereo disparity --num-disp 64 --format s16`), which the VM must reproduce from the frames it
# captures. 10 to 35 s on the 2-core build host (TCG); the VM's own limit is 170 s, the test's 200 s.
if(LPSTEREO_VM_AVAILABLE)
  find_library(LPSTEREO_PNG_STATIC NAMES libpng16.a libpng.a)
  find_library(LPSTEREO_Z_STATIC NAMES libz.a)
  if(NOT TARGET lpstereo)
    message(STATUS "VM test vivid_capture: not registered, its data need the lpstereo command line (LPSTEREO_BUILD_TOOLS)")
  elseif(NOT LPSTEREO_PNG_STATIC OR NOT LPSTEREO_Z_STATIC)
    message(STATUS "VM test vivid_capture: not registered, static libpng16.a or libz.a missing (libpng-dev, zlib1g-dev)")
  else()
    add_executable(vivid_capture_test ${LPSTEREO_VM_DIR}/vivid_capture_test.cpp)
    target_include_directories(vivid_capture_test PRIVATE ${PROJECT_SOURCE_DIR})
    target_link_libraries(vivid_capture_test PRIVATE lpstereo::camera lpstereo::arm ${LPSTEREO_PNG_STATIC}
                                                     ${LPSTEREO_Z_STATIC} m)
    target_link_options(vivid_capture_test PRIVATE -static)
    lpstereo_warnings(vivid_capture_test)

    set(vivid_data ${LPSTEREO_VM_WORK_DIR}/vivid-data)
    add_custom_command(
      OUTPUT ${vivid_data}/left.png ${vivid_data}/right.png ${vivid_data}/reference.s16
      COMMAND ${CMAKE_COMMAND} -E rm -rf ${vivid_data}/scene
      COMMAND $<TARGET_FILE:lpstereo> synth -o ${vivid_data}/scene --width 640 --height 480 --seed 3
      COMMAND ${CMAKE_COMMAND} -E copy ${vivid_data}/scene/left.png ${vivid_data}/scene/right.png ${vivid_data}/
      COMMAND $<TARGET_FILE:lpstereo> disparity ${vivid_data}/left.png ${vivid_data}/right.png
              -o ${vivid_data}/reference.s16 --format s16 --num-disp 64
      DEPENDS lpstereo
      COMMENT "vivid_capture_test data: a synthetic 640x480 pair and its disparity"
      VERBATIM)
    add_custom_target(vivid_capture_data ALL
                      DEPENDS ${vivid_data}/left.png ${vivid_data}/right.png ${vivid_data}/reference.s16)
    add_dependencies(vivid_capture_test vivid_capture_data)

    add_test(NAME Vm.vivid_capture
             COMMAND ${LPSTEREO_VM_DIR}/run-in-vm.sh --work ${LPSTEREO_VM_WORK_DIR}/vivid --timeout 170
                     --module "vivid:n_devs=2 node_types=0x101,0x101"
                     --file ${vivid_data}/left.png=/data/left.png --file ${vivid_data}/right.png=/data/right.png
                     --file ${vivid_data}/reference.s16=/data/reference.s16
                     -- $<TARGET_FILE:vivid_capture_test> /data)
    set_tests_properties(Vm.vivid_capture PROPERTIES TIMEOUT 200)
  endif()
endif()

# Vm.vivid_lpstereo_run: the host's own `lpstereo run` (dynamically linked: the VM mounts the
# host's file system read-only over virtio 9p and runs it with chroot) on two vivid cameras: a live
# run with a recording that replays, a stalled camera, an output node refused, and a camera
# unplugged mid-run (v4l2-ctl presses vivid's Disconnect) ending the run with one line, exit 1 and
# a complete recording (tests/vm/vivid_lpstereo_run.sh). About 40 s on the 2-core build host.
if(LPSTEREO_VM_AVAILABLE AND TARGET lpstereo)
  find_program(LPSTEREO_V4L2_CTL v4l2-ctl)
  if(NOT LPSTEREO_V4L2_CTL)
    message(STATUS "VM test vivid_lpstereo_run: not registered, v4l2-ctl missing (v4l-utils, scripts/install-deps.sh)")
  else()
    add_test(NAME Vm.vivid_lpstereo_run
             COMMAND ${LPSTEREO_VM_DIR}/run-in-vm.sh --work ${LPSTEREO_VM_WORK_DIR}/vivid_lpstereo_run --timeout 280
                     --host-root --module "vivid:n_devs=2 node_types=0x101,0x101"
                     -- ${LPSTEREO_VM_DIR}/vivid_lpstereo_run.sh $<TARGET_FILE:lpstereo>)
    set_tests_properties(Vm.vivid_lpstereo_run PROPERTIES TIMEOUT 300)
  endif()
endif()
