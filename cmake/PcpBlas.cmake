# Optional BLAS back end of pcp::nn::gemm (OpenBLAS). PCP_BLAS=AUTO uses it when OpenBLAS's CMake
# config is found, ON requires it, OFF never uses it. Only src/nn/gemm.cpp sees it: the define
# PCP_WITH_BLAS and OpenBLAS's include directory are set on that one source file (no
# EIGEN_USE_BLAS anywhere), and the library links pcp::openblas privately (exported as link-only;
# the installed pcpConfig.cmake finds OpenBLAS again). Sets PCP_WITH_BLAS (ON/OFF).
set(PCP_BLAS AUTO CACHE STRING "OpenBLAS back end for nn::gemm: AUTO (when found), ON (required), OFF")
set_property(CACHE PCP_BLAS PROPERTY STRINGS AUTO ON OFF)

function(pcp_setup_blas target gemm_source)
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
  set_source_files_properties("${gemm_source}" PROPERTIES
    COMPILE_DEFINITIONS PCP_WITH_BLAS=1
    INCLUDE_DIRECTORIES "${OpenBLAS_INCLUDE_DIRS}")
  target_link_libraries(${target} PRIVATE pcp::openblas)
  message(STATUS "pcp: nn::gemm back ends: eigen, blas (OpenBLAS ${OpenBLAS_VERSION}: ${OpenBLAS_LIBRARIES})")
  set(PCP_WITH_BLAS ON PARENT_SCOPE)
endfunction()
