# End-to-end test of the `lane` command, run by ctest as
#   cmake -DLANE=<lane binary> -DSRC=<source dir> -DOUT=<scratch dir> -P cli_test.cmake
foreach(var LANE SRC OUT)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "cli_test.cmake needs -D${var}=...")
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

# --- help and usage errors -------------------------------------------------
run(0 help --help)
expect_contains("${help_out}" "detect" "lane --help")
run(0 detect_help detect --help)
expect_contains("${detect_help_out}" "--overlay" "lane detect --help")
run(2 bad_option detect --config "${CONFIG}" --no-such-option x.png)
expect_contains("${bad_option_err}" "usage: lane detect" "unknown option")
run(2 bad_command frobnicate)

# --- config ----------------------------------------------------------------
run(0 config config --config "${CONFIG}" --mode two)
expect_contains("${config_out}" "\"mode\": \"two\"" "lane config --mode two")
file(WRITE "${OUT}/typo.json" "{\"detector\": {\"hough\": {\"min_peek\": 1}}}")
run(1 typo config --config "${OUT}/typo.json")
expect_contains("${typo_err}" "detector.hough.min_peek" "config with a typo")

# --- render 3 frames, detect them with overlays ----------------------------
run(0 render render --config "${CONFIG}" --count 3 --seed 7 --out "${OUT}/frames")
foreach(f 000000.png 000001.png 000002.png labels.jsonl list.txt)
  if(NOT EXISTS "${OUT}/frames/${f}")
    message(FATAL_ERROR "lane render did not write ${f}")
  endif()
endforeach()
file(STRINGS "${OUT}/frames/labels.jsonl" labels)
list(LENGTH labels n)
if(NOT n EQUAL 3)
  message(FATAL_ERROR "labels.jsonl has ${n} lines, expected 3")
endif()

run(0 detect detect --config "${CONFIG}" --output "${OUT}/results.jsonl"
    --overlay "${OUT}/overlay" "${OUT}/frames")
expect_contains("${detect_err}" "3 frames, 0 failed" "lane detect summary")
file(STRINGS "${OUT}/results.jsonl" results)
list(LENGTH results n)
if(NOT n EQUAL 3)
  message(FATAL_ERROR "results.jsonl has ${n} lines, expected 3")
endif()
set(i 0)
foreach(line IN LISTS results)
  expect_contains("${line}" "{\"schema\":1,\"frame\":\"00000${i}.png\"" "results line ${i}")
  expect_contains("${line}" "\"lanes\":[" "results line ${i}")
  expect_contains("${line}" "\"timing_ms\":{\"decode\":" "results line ${i}")
  math(EXPR i "${i} + 1")
endforeach()
foreach(f 000000.png 000000_ipm.png 000001.png 000001_ipm.png 000002.png 000002_ipm.png)
  if(NOT EXISTS "${OUT}/overlay/${f}")
    message(FATAL_ERROR "lane detect --overlay did not write ${f}")
  endif()
endforeach()

# The list file gives the same frames, to stdout.
run(0 detect_list detect --config "${CONFIG}" "${OUT}/frames/list.txt")
expect_contains("${detect_list_out}" "\"frame\":\"000002.png\"" "detect on list.txt")

# --- failures: exit code 1 with a message, never a crash -------------------
run(1 missing detect --config "${CONFIG}" "${OUT}/no-such-frame.png")
expect_contains("${missing_err}" "no-such-frame.png" "missing file")
expect_contains("${missing_out}" "\"error\":" "missing file record")

string(ASCII 255 216 255 224 jpeg_magic)
file(WRITE "${OUT}/corrupt.jpg" "${jpeg_magic}this is not a JPEG at all, just some garbage bytes")
run(1 corrupt detect --config "${CONFIG}" "${OUT}/corrupt.jpg")
expect_contains("${corrupt_err}" "corrupt.jpg" "corrupt JPEG")
expect_contains("${corrupt_out}" "\"error\":" "corrupt JPEG record")

# A bad frame among good ones: the good ones are still processed.
run(1 mixed detect --config "${CONFIG}" "${OUT}/frames/000000.png" "${OUT}/corrupt.jpg"
    "${OUT}/frames/000001.png")
expect_contains("${mixed_err}" "3 frames, 1 failed" "mixed inputs")

# A frame of the wrong size for the camera.
run(1 wrong_size detect --config "${SRC}/configs/culane-driver161.json"
    "${OUT}/frames/000000.png")
expect_contains("${wrong_size_err}" "1640x590" "wrong frame size")

message(STATUS "cli_render_detect: all checks passed")
