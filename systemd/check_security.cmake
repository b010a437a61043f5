# Runs `systemd-analyze security --offline=true` on UNIT and fails when the
# overall exposure exceeds THRESHOLD (docs/daemon.md, systemd: <= 2.0).
execute_process(COMMAND systemd-analyze security --offline=true --no-pager ${UNIT}
                OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
string(REGEX MATCH "Overall exposure level for [^:]+: ([0-9]+\\.[0-9]+)" found "${out}")
if(NOT found)
  message(FATAL_ERROR "no exposure level in the output of systemd-analyze security:\n${out}\n${err}")
endif()
set(level ${CMAKE_MATCH_1})
message(STATUS "exposure ${level} (threshold ${THRESHOLD})")
if(level GREATER THRESHOLD)
  message(FATAL_ERROR "exposure ${level} exceeds ${THRESHOLD}:\n${out}")
endif()
