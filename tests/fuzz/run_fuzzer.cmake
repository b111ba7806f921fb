# Runs one libFuzzer target for SECONDS from a fresh copy of its seed corpus (the corpus in the
# source tree is never written), inputs capped at 64 KiB, memory at 2 GB. Fails on any finding;
# the crashing input is left in WORK (crash-*, leak-*, oom-*, timeout-*).
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}/corpus")
file(GLOB seeds "${CORPUS}/*")
if(NOT seeds)
  message(FATAL_ERROR "no seed corpus in ${CORPUS}")
endif()
file(COPY ${seeds} DESTINATION "${WORK}/corpus")
execute_process(
  COMMAND "${FUZZER}" -max_total_time=${SECONDS} -max_len=65536 -rss_limit_mb=2048 -timeout=10
          -print_final_stats=1 "-artifact_prefix=${WORK}/" "${WORK}/corpus"
  WORKING_DIRECTORY "${WORK}"
  RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "${FUZZER}: a finding (exit ${status}); its input is in ${WORK}")
endif()
