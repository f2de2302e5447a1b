# Cross-build for 64-bit ARM (aarch64) with Debian's g++-aarch64-linux-gnu, against an arm64 sysroot
# unpacked from Debian's arm64 packages (scripts/make-arm64-sysroot.sh: OpenCV, libcamera, libpng and
# the libraries they load). CTest and scripts/check.sh run the binaries through qemu-aarch64
# (Debian's qemu-user) with that sysroot as the target's root.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
# Fail early, in one line, when the cross tools are missing (scripts/install-deps.sh installs them).
find_program(LPSTEREO_AARCH64_CXX aarch64-linux-gnu-g++)
if(NOT LPSTEREO_AARCH64_CXX)
  message(FATAL_ERROR "aarch64 cross compiler aarch64-linux-gnu-g++ not found: install Debian's g++-aarch64-linux-gnu (scripts/install-deps.sh)")
endif()
find_program(LPSTEREO_QEMU_AARCH64 qemu-aarch64)
if(NOT LPSTEREO_QEMU_AARCH64)
  message(FATAL_ERROR "qemu-aarch64 not found (it runs the cross-built tests): install Debian's qemu-user (scripts/install-deps.sh)")
endif()
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)

# The sysroot: build/arm64-sysroot of the source tree unless LPSTEREO_AARCH64_SYSROOT names another
# (a cache variable, or the environment variable of that name). It is assembled here when missing or
# when its package list changed (the script returns at once otherwise), so a fresh clone's
# `cmake --preset aarch64` needs only the network to Debian's registry.
if(NOT LPSTEREO_AARCH64_SYSROOT)
  if(DEFINED ENV{LPSTEREO_AARCH64_SYSROOT})
    set(LPSTEREO_AARCH64_SYSROOT $ENV{LPSTEREO_AARCH64_SYSROOT})
  else()
    cmake_path(SET LPSTEREO_AARCH64_SYSROOT NORMALIZE "${CMAKE_CURRENT_LIST_DIR}/../build/arm64-sysroot")
  endif()
endif()
# try_compile projects run this file again: only the top-level configure assembles the sysroot.
get_property(lpstereo_in_try_compile GLOBAL PROPERTY IN_TRY_COMPILE)
if(NOT lpstereo_in_try_compile)
  execute_process(COMMAND ${CMAKE_CURRENT_LIST_DIR}/../scripts/make-arm64-sysroot.sh ${LPSTEREO_AARCH64_SYSROOT}
                  RESULT_VARIABLE lpstereo_sysroot_result)
  if(NOT lpstereo_sysroot_result EQUAL 0)
    message(FATAL_ERROR "arm64 sysroot ${LPSTEREO_AARCH64_SYSROOT} could not be assembled (scripts/make-arm64-sysroot.sh exited ${lpstereo_sysroot_result}; its message is above)")
  endif()
endif()
set(LPSTEREO_AARCH64_SYSROOT ${LPSTEREO_AARCH64_SYSROOT} CACHE PATH "arm64 sysroot unpacked from Debian's packages (scripts/make-arm64-sysroot.sh)")

# Headers and libraries come from the sysroot (--sysroot: Debian's multiarch directories
# usr/include/aarch64-linux-gnu and usr/lib/aarch64-linux-gnu are searched under it, also for the
# DT_NEEDED entries of the libraries linked). The C and C++ runtimes are the cross compiler's own
# (see scripts/make-arm64-sysroot.sh for why that matches what runs).
set(CMAKE_SYSROOT ${LPSTEREO_AARCH64_SYSROOT})
set(CMAKE_FIND_ROOT_PATH ${LPSTEREO_AARCH64_SYSROOT})
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
# pkg-config (libcamera) reads only the sysroot's .pc files and prefixes the paths they give.
set(ENV{PKG_CONFIG_SYSROOT_DIR} ${LPSTEREO_AARCH64_SYSROOT})
set(ENV{PKG_CONFIG_LIBDIR} "${LPSTEREO_AARCH64_SYSROOT}/usr/lib/aarch64-linux-gnu/pkgconfig:${LPSTEREO_AARCH64_SYSROOT}/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_PATH} "")
# qemu-aarch64 -L: the target's dynamic linker and libraries are looked up under the sysroot.
set(CMAKE_CROSSCOMPILING_EMULATOR ${LPSTEREO_QEMU_AARCH64} -L ${LPSTEREO_AARCH64_SYSROOT})
