# Warning flags for libpcp's own targets. No -ffast-math anywhere: it would silently disable the
# NaN/Inf input checks and change gradients.
function(pcp_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wno-unknown-pragmas)
  if(PCP_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
