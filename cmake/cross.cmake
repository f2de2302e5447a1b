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
