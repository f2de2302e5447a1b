# Instruction-set levels the kernels are compiled for (kernels/simd/native.h explains the scheme).
# Each level: a name, the LPSTEREO_ISA_TU number, and its compiler flags.
set(LPSTEREO_ISA_LEVELS "")
if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$")
  list(APPEND LPSTEREO_ISA_LEVELS sse42 avx2 avx512 avx512_icl)
  set(LPSTEREO_ISA_TU_sse42 1)
  set(LPSTEREO_ISA_TYPE_sse42 Sse42)
  set(LPSTEREO_ISA_FLAGS_sse42 -msse4.2 -mpopcnt)
  set(LPSTEREO_ISA_TU_avx2 2)
  set(LPSTEREO_ISA_TYPE_avx2 Avx2)
  set(LPSTEREO_ISA_FLAGS_avx2 -mavx2 -mbmi2 -mpopcnt)
  set(LPSTEREO_ISA_TU_avx512 3)
  set(LPSTEREO_ISA_TYPE_avx512 Avx512)
  set(LPSTEREO_ISA_FLAGS_avx512 -mavx512f -mavx512bw -mavx512vl -mavx512dq -mbmi2 -mpopcnt)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    # GCC 12's own AVX-512 intrinsics (_mm512_undefined_epi32, a deliberate self-initialisation used
    # as the pass-through of unmasked ops) trip -Wmaybe-uninitialized once inlined (GCC PR 105593,
    # fixed in GCC 13). Inlined deep enough (the zip permutes inside SGM's lane minimum), the same
    # self-initialisation is reported as -Wuninitialized.
    list(APPEND LPSTEREO_ISA_FLAGS_avx512 -Wno-maybe-uninitialized -Wno-uninitialized)
  endif()
  # AVX-512 of Ice Lake and later: the avx512 flags plus VPOPCNTDQ and BITALG (popcounts in one
  # instruction; kernels/simd/x86_avx512.h compiles as the struct Avx512Icl here).
  set(LPSTEREO_ISA_TU_avx512_icl 5)
  set(LPSTEREO_ISA_TYPE_avx512_icl Avx512Icl)
  set(LPSTEREO_ISA_FLAGS_avx512_icl ${LPSTEREO_ISA_FLAGS_avx512} -mavx512vpopcntdq -mavx512bitalg)
elseif(CMAKE_SYSTEM_PROCESSOR MATCHES "^(aarch64|arm64)$")
  list(APPEND LPSTEREO_ISA_LEVELS neon)
  set(LPSTEREO_ISA_TU_neon 4)
  set(LPSTEREO_ISA_TYPE_neon Neon)
  set(LPSTEREO_ISA_FLAGS_neon "")
endif()
message(STATUS "lpstereo: native ISA levels compiled: scalar ${LPSTEREO_ISA_LEVELS}")

# Compiles SOURCES once per ISA level above (object library <target>_<level>, with the level's flags
# and LPSTEREO_ISA_TU, as kernels/CMakeLists.txt does for the kernels), links the objects into
# <target>, and defines <DEFINE_PREFIX>_<LEVEL>=1 on <target> for each level built.
# Used by tests that need per-ISA code of their own (tests/kernels/simd_ops_probe.cpp).
function(lpstereo_add_per_isa_sources target)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "DEFINE_PREFIX" "SOURCES")
  foreach(level IN LISTS LPSTEREO_ISA_LEVELS)
    string(TOUPPER ${level} level_upper)
    set(objects ${target}_${level})
    add_library(${objects} OBJECT ${arg_SOURCES})
    target_include_directories(${objects} PRIVATE ${PROJECT_SOURCE_DIR})
    target_compile_definitions(${objects} PRIVATE LPSTEREO_ISA_TU=${LPSTEREO_ISA_TU_${level}})
    target_compile_options(${objects} PRIVATE ${LPSTEREO_ISA_FLAGS_${level}})
    lpstereo_warnings(${objects})
    target_sources(${target} PRIVATE $<TARGET_OBJECTS:${objects}>)
    target_compile_definitions(${target} PRIVATE ${arg_DEFINE_PREFIX}_${level_upper}=1)
  endforeach()
endfunction()
