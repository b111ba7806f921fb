# Warning flags for libpcp's own targets. No -ffast-math anywhere: it would silently disable the
# NaN/Inf input checks and change gradients.
function(pcp_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wno-unknown-pragmas)
  if(PCP_SANITIZE)
    # GCC 12 reports false -Wmaybe-uninitialized inside std::regex (used by cxxopts) when the
    # sanitizers are on; with -Werror that would stop the build, so that one warning is off there.
    target_compile_options(${target} PRIVATE -Wno-maybe-uninitialized)
  endif()
  if(PCP_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
