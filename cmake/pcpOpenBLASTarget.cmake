# Defines the imported target pcp::openblas (link only) from the variables of OpenBLAS's own CMake
# config (OpenBLAS_LIBRARIES, OpenBLAS_INCLUDE_DIRS; Debian's libopenblas*-dev ship it but no
# target). Included by libpcp's build and by the installed pcpConfig.cmake after
# find_package/find_dependency(OpenBLAS CONFIG), so that the exported pcp::pcp can name it.
if(NOT TARGET pcp::openblas)
  add_library(pcp::openblas INTERFACE IMPORTED)
  set_target_properties(pcp::openblas PROPERTIES INTERFACE_LINK_LIBRARIES "${OpenBLAS_LIBRARIES}")
endif()
