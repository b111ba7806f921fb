# Installs the build tree into a fresh prefix, then configures, builds and runs tests/consumer
# against it. Invoked by CTest with -DPCP_BUILD_DIR, -DPCP_CONSUMER_DIR, -DPCP_WORK_DIR.
file(REMOVE_RECURSE "${PCP_WORK_DIR}")
set(prefix "${PCP_WORK_DIR}/prefix")
function(run)
  execute_process(COMMAND ${ARGV} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "command failed (${rc}): ${ARGV}\n${out}\n${err}")
  endif()
  message(STATUS "${out}")
endfunction()
run(${CMAKE_COMMAND} --install "${PCP_BUILD_DIR}" --prefix "${prefix}")
run(${CMAKE_COMMAND} -S "${PCP_CONSUMER_DIR}" -B "${PCP_WORK_DIR}/build" -G "${PCP_GENERATOR}"
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build "${PCP_WORK_DIR}/build")
execute_process(COMMAND "${PCP_WORK_DIR}/build/consumer" WORKING_DIRECTORY "${PCP_WORK_DIR}" RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "consumer failed (${rc})")
endif()
