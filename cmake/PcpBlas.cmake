# Optional BLAS back end of pcp::nn::gemm (OpenBLAS). PCP_BLAS=AUTO uses it when OpenBLAS's CMake
# config is found, ON requires it, OFF never uses it. When found, the back end's own source file
# (src/nn/gemm_blas.cpp, the only file that includes cblas.h) is added to the library with
# OpenBLAS's include directory on it, and the dispatcher src/nn/gemm.cpp gets the define
# PCP_WITH_BLAS (no EIGEN_USE_BLAS anywhere); when not found, that file is not compiled at all.
# The library links pcp::openblas privately (exported as link-only; the installed
# pcpConfig.cmake finds OpenBLAS again). Sets PCP_WITH_BLAS (ON/OFF).
set(PCP_BLAS AUTO CACHE STRING "OpenBLAS back end for nn::gemm: AUTO (when found), ON (required), OFF")
set_property(CACHE PCP_BLAS PROPERTY STRINGS AUTO ON OFF)

function(pcp_setup_blas target dispatcher_source backend_source)
  set(PCP_WITH_BLAS OFF PARENT_SCOPE)
  if(PCP_BLAS STREQUAL "OFF")
    message(STATUS "pcp: nn::gemm back ends: eigen (PCP_BLAS=OFF)")
    return()
  elseif(PCP_BLAS STREQUAL "ON")
    find_package(OpenBLAS CONFIG REQUIRED)
  elseif(PCP_BLAS STREQUAL "AUTO")
    find_package(OpenBLAS CONFIG QUIET)
  else()
    message(FATAL_ERROR "PCP_BLAS must be AUTO, ON or OFF (got '${PCP_BLAS}')")
  endif()
  if(NOT OpenBLAS_FOUND OR NOT OpenBLAS_LIBRARIES)
    message(STATUS "pcp: nn::gemm back ends: eigen (OpenBLAS not found)")
    return()
  endif()
  include(pcpOpenBLASTarget)
  target_sources(${target} PRIVATE "${backend_source}")
  # As system headers: OpenBLAS's config header uses C99 _Complex, which -Wpedantic -Werror refuses.
  foreach(dir ${OpenBLAS_INCLUDE_DIRS})
    set_property(SOURCE "${backend_source}" APPEND PROPERTY COMPILE_OPTIONS "-isystem${dir}")
  endforeach()
  set_property(SOURCE "${dispatcher_source}" APPEND PROPERTY COMPILE_DEFINITIONS PCP_WITH_BLAS=1)
  target_link_libraries(${target} PRIVATE pcp::openblas)
  message(STATUS "pcp: nn::gemm back ends: eigen, blas (OpenBLAS ${OpenBLAS_VERSION}: ${OpenBLAS_LIBRARIES})")
  set(PCP_WITH_BLAS ON PARENT_SCOPE)
endfunction()
