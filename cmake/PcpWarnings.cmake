# Warning flags for libpcp's own targets. No -ffast-math anywhere: it would silently disable the
# NaN/Inf input checks and change gradients.
include(CheckCXXSourceCompiles)

# GCC 12's AVX-512 intrinsics initialise `_mm*_undefined_*` values from themselves (GCC bug
# 105593, fixed in GCC 13). Wherever Eigen's AVX-512 code is inlined into our sources (built with
# -march=native on a CPU with AVX-512), GCC 12 reports -Wuninitialized / -Wmaybe-uninitialized in
# its own avx512fintrin.h, and -Werror would stop the build. Detected once here.
set(PCP_GCC12_AVX512 OFF)
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13 AND PCP_NATIVE)
  set(CMAKE_REQUIRED_FLAGS "-march=native")
  check_cxx_source_compiles("
    #ifndef __AVX512F__
    #error no AVX-512
    #endif
    int main() { return 0; }" PCP_NATIVE_HAS_AVX512)
  unset(CMAKE_REQUIRED_FLAGS)
  if(PCP_NATIVE_HAS_AVX512)
    set(PCP_GCC12_AVX512 ON)
  endif()
endif()

function(pcp_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wno-unknown-pragmas)
  if(PCP_SANITIZE AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    # GCC 12 reports false -Wmaybe-uninitialized inside std::regex (used by cxxopts) when the
    # sanitizers are on; with -Werror that would stop the build, so that one warning is off there.
    target_compile_options(${target} PRIVATE -Wno-maybe-uninitialized)
  endif()
  if(PCP_GCC12_AVX512)
    target_compile_options(${target} PRIVATE -Wno-uninitialized -Wno-maybe-uninitialized)
  endif()
  if(PCP_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# Code that parses options and calls the library, or checks its results (the apps' own files and
# the tests): -O1 where the build type optimises; the library keeps the build type's flags. Under
# PCP_SANITIZE (the library at -O1, scripts/test.sh) this code is built at -O0: an -O1 build with
# ASan + UBSan compiles three times slower than -O3, and most of the sanitizer run's time was
# compiling these. Their compute runs in the library (except the gradient checks' reference
# forward, tests/nn/test_nn_gradients.cpp, and the mesh tests' analytic distances: those files are
# built at -O1 there, tests/CMakeLists.txt). The README's test command has a time budget.
function(pcp_light_code_opt target)
  if(PCP_SANITIZE)
    target_compile_options(${target} PRIVATE -O0)
  elseif(CMAKE_BUILD_TYPE MATCHES "^(Release|RelWithDebInfo|MinSizeRel)$")
    target_compile_options(${target} PRIVATE -O1)
  endif()
endfunction()
