# Optional oneDNN back end of pcp::nn::gemm: the bf16 products of --precision bf16 (issue 7).
# PCP_DNNL=AUTO uses it when oneDNN (Debian libdnnl-dev) is found, ON requires it, OFF never uses
# it. Found by header and library, not by oneDNN's CMake package: Debian's dnnl-config.cmake
# requires OpenCL and fails the whole configuration without it, even when asked QUIET. Like the
# BLAS back end: when found, the back end's own source file (src/nn/gemm_dnnl.cpp, the only file
# that includes oneDNN) is added to the library with oneDNN's include directory on it, and the
# dispatcher src/nn/gemm.cpp gets the define PCP_WITH_DNNL; when not found, that file is not
# compiled at all. The static library links pcp::dnnl privately (exported link-only; the installed
# pcpConfig.cmake finds the library again). Sets PCP_WITH_DNNL (ON/OFF) and PCP_DNNL_LIBRARY.
set(PCP_DNNL AUTO CACHE STRING "oneDNN bf16 back end for nn::gemm: AUTO (when found), ON (required), OFF")
set_property(CACHE PCP_DNNL PROPERTY STRINGS AUTO ON OFF)

function(pcp_setup_dnnl target dispatcher_source backend_source)
  set(PCP_WITH_DNNL OFF PARENT_SCOPE)
  if(PCP_DNNL STREQUAL "OFF")
    message(STATUS "pcp: bf16 precision: no (PCP_DNNL=OFF)")
    return()
  elseif(NOT PCP_DNNL STREQUAL "AUTO" AND NOT PCP_DNNL STREQUAL "ON")
    message(FATAL_ERROR "PCP_DNNL must be AUTO, ON or OFF (got '${PCP_DNNL}')")
  endif()
  find_path(PCP_DNNL_INCLUDE_DIR oneapi/dnnl/dnnl.hpp)
  find_library(PCP_DNNL_LIBRARY dnnl)
  if(NOT PCP_DNNL_INCLUDE_DIR OR NOT PCP_DNNL_LIBRARY)
    if(PCP_DNNL STREQUAL "ON")
      message(FATAL_ERROR "PCP_DNNL=ON but oneDNN was not found (apt-get install libdnnl-dev)")
    endif()
    message(STATUS "pcp: bf16 precision: no (oneDNN not found; apt-get install libdnnl-dev)")
    return()
  endif()
  include(pcpDnnlTarget)
  target_sources(${target} PRIVATE "${backend_source}")
  # Not for a compiler's own directory (/usr/include): naming it again breaks #include_next.
  if(NOT PCP_DNNL_INCLUDE_DIR IN_LIST CMAKE_CXX_IMPLICIT_INCLUDE_DIRECTORIES)
    set_property(SOURCE "${backend_source}" APPEND PROPERTY INCLUDE_DIRECTORIES "${PCP_DNNL_INCLUDE_DIR}")
  endif()
  set_property(SOURCE "${dispatcher_source}" APPEND PROPERTY COMPILE_DEFINITIONS PCP_WITH_DNNL=1)
  target_link_libraries(${target} PRIVATE pcp::dnnl)
  message(STATUS "pcp: bf16 precision: oneDNN (${PCP_DNNL_LIBRARY}), used where the CPU has AVX512-BF16 or AMX")
  set(PCP_WITH_DNNL ON PARENT_SCOPE)
endfunction()
