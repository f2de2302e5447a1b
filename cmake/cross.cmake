# Helpers for cross builds (the aarch64 preset, cmake/aarch64-linux-gnu.cmake). On a native build
# they do nothing.
#
# The toolchain file restricts find_package to the target sysroot. The library parts need only
# header-only, architecture-independent packages (Eigen, nlohmann JSON), which Debian installs for
# the build machine only; they are found there instead, and their headers are exposed to the cross
# compiler without exposing the build machine's /usr/include (its C library headers would shadow
# the target's).

if(CMAKE_CROSSCOMPILING)
  set(LPSTEREO_HOST_HEADER_ONLY_FIND NO_CMAKE_FIND_ROOT_PATH)
else()
  set(LPSTEREO_HOST_HEADER_ONLY_FIND "")
endif()

# For a header-only imported target found on the build machine: an include directory that is a
# general system root (/usr/include, /usr/local/include) is replaced by a directory in the build
# tree holding links to just the package's own entries under that root (ROOT_ENTRIES, e.g.
# "nlohmann"). Other include directories (/usr/include/eigen3) are the package's alone and stay.
#   lpstereo_use_host_headers(<imported target> [ROOT_ENTRIES <entry>...])
function(lpstereo_use_host_headers target)
  if(NOT CMAKE_CROSSCOMPILING)
    return()
  endif()
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "" "ROOT_ENTRIES")
  get_target_property(directories ${target} INTERFACE_INCLUDE_DIRECTORIES)
  list(REMOVE_DUPLICATES directories)
  string(MAKE_C_IDENTIFIER ${target} staged_name)
  set(staged ${CMAKE_BINARY_DIR}/host-headers/${staged_name})
  set(result "")
  foreach(directory IN LISTS directories)
    if(directory MATCHES "^/usr(/local)?/include/?$")
      if(NOT arg_ROOT_ENTRIES)
        message(FATAL_ERROR "lpstereo_use_host_headers: ${target} uses ${directory}; name its ROOT_ENTRIES")
      endif()
      file(MAKE_DIRECTORY ${staged})
      foreach(entry IN LISTS arg_ROOT_ENTRIES)
        if(NOT EXISTS ${directory}/${entry})
          message(FATAL_ERROR "lpstereo_use_host_headers: ${directory}/${entry} not found for ${target}")
        endif()
        file(CREATE_LINK ${directory}/${entry} ${staged}/${entry} SYMBOLIC)
      endforeach()
      list(APPEND result ${staged})
    else()
      list(APPEND result ${directory})
    endif()
  endforeach()
  list(REMOVE_DUPLICATES result)
  set_property(TARGET ${target} PROPERTY INTERFACE_INCLUDE_DIRECTORIES ${result})
  message(STATUS "lpstereo: ${target} headers for the cross build: ${result}")
endfunction()

# GoogleTest for the target: Debian ships its source (libgtest-dev: /usr/src/googletest); it is built
# with the cross compiler as part of this project, under the names find_package(GTest) gives.
function(lpstereo_build_gtest_for_target)
  set(LPSTEREO_GTEST_SOURCE_DIR /usr/src/googletest CACHE PATH "GoogleTest source tree built for cross builds")
  if(NOT EXISTS ${LPSTEREO_GTEST_SOURCE_DIR}/CMakeLists.txt)
    message(FATAL_ERROR "GoogleTest source not found in ${LPSTEREO_GTEST_SOURCE_DIR} (Debian: libgtest-dev)")
  endif()
  set(INSTALL_GTEST OFF CACHE BOOL "Install GoogleTest (off: built for the cross build only)" FORCE)
  add_subdirectory(${LPSTEREO_GTEST_SOURCE_DIR} ${CMAKE_BINARY_DIR}/googletest EXCLUDE_FROM_ALL SYSTEM)
  # GCC 12 reports false -Wrestrict positives inside std::string (GCC bug 105329; see warnings.cmake).
  target_compile_options(gtest PRIVATE -Wno-restrict)
  foreach(library gtest gtest_main gmock gmock_main)
    if(TARGET ${library} AND NOT TARGET GTest::${library})
      add_library(GTest::${library} ALIAS ${library})
    endif()
  endforeach()
endfunction()

# OpenCV for the target, from the sysroot (scripts/make-arm64-sysroot.sh). Debian's OpenCVConfig.cmake
# (libopencv-dev) refuses to load unless the library of every one of its ~50 modules is installed,
# and their closure (Qt, VTK, FFmpeg, GStreamer and their -dev packages) is most of a gigabyte; the
# sysroot holds only the modules lpstereo links, imported here under the names OpenCV's config gives
# (opencv_core, ...). Sets OpenCV_INCLUDE_DIRS and OpenCV_LIBS as find_package(OpenCV) does.
#   lpstereo_find_target_opencv(REQUIRED <module>... [OPTIONAL <module>...])
# An OPTIONAL module missing from the sysroot has no target (if(TARGET opencv_<module>) tells).
function(lpstereo_find_target_opencv)
  cmake_parse_arguments(PARSE_ARGV 0 arg "" "" "REQUIRED;OPTIONAL")
  find_path(LPSTEREO_TARGET_OPENCV_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4)
  if(NOT LPSTEREO_TARGET_OPENCV_INCLUDE_DIR)
    message(FATAL_ERROR "OpenCV headers (opencv4/opencv2/core.hpp) not found in the sysroot ${CMAKE_SYSROOT}: scripts/make-arm64-sysroot.sh unpacks libopencv-core-dev there")
  endif()
  set(libraries "")
  foreach(module IN LISTS arg_REQUIRED arg_OPTIONAL)
    find_library(LPSTEREO_TARGET_OPENCV_${module}_LIBRARY opencv_${module})
    if(NOT LPSTEREO_TARGET_OPENCV_${module}_LIBRARY)
      if(module IN_LIST arg_REQUIRED)
        message(FATAL_ERROR "libopencv_${module}.so not found in the sysroot ${CMAKE_SYSROOT}: add libopencv-${module}-dev and libopencv-${module}406 to scripts/make-arm64-sysroot.sh")
      endif()
      message(STATUS "lpstereo: OpenCV ${module} is not in the sysroot; what needs it is not built")
      continue()
    endif()
    add_library(opencv_${module} SHARED IMPORTED GLOBAL)
    set_target_properties(opencv_${module} PROPERTIES
      IMPORTED_LOCATION ${LPSTEREO_TARGET_OPENCV_${module}_LIBRARY}
      INTERFACE_INCLUDE_DIRECTORIES ${LPSTEREO_TARGET_OPENCV_INCLUDE_DIR})
    list(APPEND libraries opencv_${module})
  endforeach()
  message(STATUS "lpstereo: OpenCV for the target from ${LPSTEREO_TARGET_OPENCV_INCLUDE_DIR}: ${libraries}")
  set(OpenCV_INCLUDE_DIRS ${LPSTEREO_TARGET_OPENCV_INCLUDE_DIR} PARENT_SCOPE)
  set(OpenCV_LIBS ${libraries} PARENT_SCOPE)
endfunction()
