# Warning flags for libpcp's own targets. No -ffast-math anywhere: it would silently disable the
# NaN/Inf input checks and change gradients.
function(pcp_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wno-unknown-pragmas)
  if(PCP_SANITIZE OR (CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13))
    # GCC 12 reports false -Wmaybe-uninitialized (1) inside std::regex (used by cxxopts) when the
    # sanitizers are on, and (2) on CPUs with AVX-512 under -march=native, in its own
    # avx512fintrin.h (`_mm256_undefined_pd` initialises itself; GCC bug 105593, fixed in GCC 13)
    # wherever Eigen's AVX-512 reductions are inlined. With -Werror either would stop the build,
    # so that one warning is off there.
    target_compile_options(${target} PRIVATE -Wno-maybe-uninitialized)
  endif()
  if(PCP_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
