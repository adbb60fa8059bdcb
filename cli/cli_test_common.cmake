# What the end-to-end tests of `lane` (cli_test.cmake, eval_cli_test.cmake)
# share: the -D variables, a fresh scratch folder, and the run and
# expect_contains macros.
foreach(var LANE SRC OUT)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "${CMAKE_SCRIPT_MODE_FILE} needs -D${var}=...")
  endif()
endforeach()

file(REMOVE_RECURSE "${OUT}")
file(MAKE_DIRECTORY "${OUT}")
set(CONFIG "${SRC}/configs/synthetic.json")

# run(<expected exit code> <name> args...): runs lane, keeps stdout/stderr in
# ${name}_out / ${name}_err, fails unless the exit code is the expected one
# (a crash reports a signal name instead of a number).
macro(run expected name)
  execute_process(COMMAND "${LANE}" ${ARGN}
                  RESULT_VARIABLE ${name}_rc OUTPUT_VARIABLE ${name}_out
                  ERROR_VARIABLE ${name}_err TIMEOUT 240)
  if(NOT "${${name}_rc}" STREQUAL "${expected}")
    message(FATAL_ERROR "lane ${ARGN}\nexit: ${${name}_rc} (expected ${expected})\n"
                        "stdout:\n${${name}_out}\nstderr:\n${${name}_err}")
  endif()
endmacro()

macro(expect_contains text part what)
  string(FIND "${text}" "${part}" _pos)
  if(_pos EQUAL -1)
    message(FATAL_ERROR "${what}: expected to contain '${part}', got:\n${text}")
  endif()
endmacro()
