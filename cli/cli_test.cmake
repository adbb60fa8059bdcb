# End-to-end test of the `lane` command, run by ctest as
#   cmake -DLANE=<lane binary> -DSRC=<source dir> -DOUT=<scratch dir> -P cli_test.cmake
include(${CMAKE_CURRENT_LIST_DIR}/cli_test_common.cmake)

# --- help and usage errors -------------------------------------------------
run(0 help --help)
expect_contains("${help_out}" "detect" "lane --help")
run(0 detect_help detect --help)
expect_contains("${detect_help_out}" "--overlay" "lane detect --help")
run(2 bad_option detect --config "${CONFIG}" --no-such-option x.png)
expect_contains("${bad_option_err}" "usage: lane detect" "unknown option")
run(2 bad_command frobnicate)
run(2 no_command)
run(0 version --version)
expect_contains("${version_out}" "lane 0." "lane --version")
run(2 bad_mode detect --config "${CONFIG}" --mode three x.png)
run(2 bad_seed detect --config "${CONFIG}" --seed -1 x.png)
run(2 no_input detect --config "${CONFIG}")
run(2 bad_count render --config "${CONFIG}" --count 0 --output "${OUT}/none")

# --- config ----------------------------------------------------------------
run(0 config config --config "${CONFIG}" --mode two)
expect_contains("${config_out}" "\"mode\": \"two\"" "lane config --mode two")
file(WRITE "${OUT}/typo.json" "{\"detector\": {\"hough\": {\"min_peek\": 1}}}")
run(1 typo config --config "${OUT}/typo.json")
expect_contains("${typo_err}" "detector.hough.min_peek" "config with a typo")

# --- render 3 frames, detect them with overlays ----------------------------
run(0 render render --config "${CONFIG}" --count 3 --seed 7 --output "${OUT}/frames")
foreach(f 000000.png 000001.png 000002.png labels.jsonl list.txt)
  if(NOT EXISTS "${OUT}/frames/${f}")
    message(FATAL_ERROR "lane render did not write ${f}")
  endif()
endforeach()
# The old spelling --out is an alias of --output.
run(0 render_out render --config "${CONFIG}" --count 1 --out "${OUT}/frames-out")
if(NOT EXISTS "${OUT}/frames-out/000000.png")
  message(FATAL_ERROR "lane render --out did not write 000000.png")
endif()
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

# --- JPEG frames: decoded only where the detector reads (the default) give
# the lanes of whole frames (--full-decode) --------------------------------
run(0 render_jpg render --config "${CONFIG}" --count 3 --seed 11 --format jpg
    --output "${OUT}/jpg")
run(0 detect_fast detect --config "${CONFIG}" --output "${OUT}/fast.jsonl" "${OUT}/jpg")
run(0 detect_full detect --config "${CONFIG}" --full-decode --output "${OUT}/full.jsonl"
    "${OUT}/jpg")
file(READ "${OUT}/fast.jsonl" fast)
file(READ "${OUT}/full.jsonl" full)
string(REGEX REPLACE ",\"timing_ms\":{[^}]*}" "" fast "${fast}")
string(REGEX REPLACE ",\"timing_ms\":{[^}]*}" "" full "${full}")
expect_contains("${fast}" "\"lanes\":[{\"image\"" "lanes found in the JPEG frames")
if(NOT fast STREQUAL full)
  message(FATAL_ERROR "lane detect on JPEG frames: the default and --full-decode differ:\n${fast}\n${full}")
endif()

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
