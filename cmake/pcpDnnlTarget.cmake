# Defines the imported target pcp::dnnl (link only) for oneDNN's shared library. Included by
# libpcp's build (PCP_DNNL_LIBRARY found there) and by the installed pcpConfig.cmake, which finds
# the library again on the consumer's machine.
if(NOT TARGET pcp::dnnl)
  if(NOT PCP_DNNL_LIBRARY)
    find_library(PCP_DNNL_LIBRARY dnnl)
  endif()
  if(NOT PCP_DNNL_LIBRARY)
    message(FATAL_ERROR "pcp was built with oneDNN (bf16 back end) but libdnnl was not found (apt-get install libdnnl-dev)")
  endif()
  add_library(pcp::dnnl INTERFACE IMPORTED)
  set_target_properties(pcp::dnnl PROPERTIES INTERFACE_LINK_LIBRARIES "${PCP_DNNL_LIBRARY}")
endif()
