# `lane calibrate` end to end: frames rendered through the synthetic camera
# (pitch 14, yaw 0), with a card's barcode reflected in the windscreen at
# the same place in every frame, give a config whose camera is that one
# again and whose static mask holds the card; bad input fails cleanly.
include(${CMAKE_CURRENT_LIST_DIR}/cli_test_common.cmake)

run(0 render render --config ${CONFIG} --count 40 --seed 7 --static-overlay
    --output ${OUT}/frames)
run(0 calibrate calibrate ${OUT}/frames --height-m 2.1798 --focal-px 344.2161
    --principal-point 317.9034,256.5352 --output ${OUT}/calibrated.json
    --overlay ${OUT}/check.png)
expect_contains("${calibrate_out}" "vanishing point" "calibrate output")
expect_contains("${calibrate_out}" "(given)" "calibrate output: the focal length was given")
if(NOT EXISTS ${OUT}/check.png)
  message(FATAL_ERROR "lane calibrate --overlay wrote no ${OUT}/check.png")
endif()
# The written config loads (its header is comments) and holds the camera.
run(0 show config --config ${OUT}/calibrated.json)
string(JSON pitch GET "${show_out}" camera pitch_deg)
string(JSON yaw GET "${show_out}" camera yaw_deg)
string(JSON view GET "${show_out}" ipm view)
if(pitch LESS 13.7 OR pitch GREATER 14.3 OR yaw LESS -0.3 OR yaw GREATER 0.3)
  message(FATAL_ERROR "calibrated pitch ${pitch}, yaw ${yaw}: expected 14 +- 0.3 and 0 +- 0.3\n"
                      "${calibrate_out}")
endif()
if(NOT view STREQUAL "ground")
  message(FATAL_ERROR "calibrated config's view is ${view}, expected ground")
endif()
# The card is fixed to the camera: masked (u 422-563, v 307-350 in 640x480).
string(JSON masked LENGTH "${show_out}" ipm static_mask)
string(JSON mask_left GET "${show_out}" ipm static_mask 0 left)
string(JSON mask_top GET "${show_out}" ipm static_mask 0 top)
if(NOT masked EQUAL 1 OR mask_left LESS 414 OR mask_left GREATER 445 OR mask_top LESS 299
   OR mask_top GREATER 320)
  message(FATAL_ERROR "calibrated config's static mask: ${masked} rectangles, the first at "
                      "(${mask_left}, ${mask_top}); expected one at the card\n${calibrate_out}")
endif()
expect_contains("${calibrate_out}" "static structure" "calibrate output: the static structure")
# ... and detects lanes on the rendered frames.
run(0 detect detect --config ${OUT}/calibrated.json --output ${OUT}/lanes.jsonl --quiet
    ${OUT}/frames)
file(STRINGS ${OUT}/lanes.jsonl records)
list(LENGTH records n)
if(NOT n EQUAL 40)
  message(FATAL_ERROR "lane detect with the calibrated config: ${n} records, expected 40")
endif()

expect_contains("${calibrate_out}" "self-check" "calibrate output: the self-check ran")
expect_contains("${calibrate_out}" "95 % interval" "calibrate output: the interval")

# A camera height 2.4 times too large: the same vanishing point, but the
# lanes come out 2.4 times too far apart on the ground. The self-check
# refuses it (exit 1, the reason, no config).
run(1 tall calibrate ${OUT}/frames --height-m 5.2 --focal-px 344.2161
    --principal-point 317.9034,256.5352 --output ${OUT}/tall.json)
if(EXISTS ${OUT}/tall.json)
  message(FATAL_ERROR "lane calibrate wrote a config that failed its self-check")
endif()
expect_contains("${tall_err}" "failed its self-check" "calibrate with a wrong height")
expect_contains("${tall_err}" "no config written" "calibrate with a wrong height")

# The card's bars meet at one point in every frame: let them vote and the
# first pass goes there; the estimate is refused, and --overlay shows who
# voted for it.
run(1 astray calibrate ${OUT}/frames --height-m 2.1798 --focal-px 344.2161
    --principal-point 317.9034,256.5352 --keep-static-structure --output ${OUT}/astray.json
    --overlay ${OUT}/astray.png)
expect_contains("${astray_err}" "meet elsewhere" "calibrate with the card voting")
if(EXISTS ${OUT}/astray.json)
  message(FATAL_ERROR "lane calibrate wrote a config for a refused estimate")
endif()
if(NOT EXISTS ${OUT}/astray.png)
  message(FATAL_ERROR "lane calibrate --overlay wrote no ${OUT}/astray.png for a refused estimate")
endif()

# Frames without markings: a clear failure, not a config.
file(MAKE_DIRECTORY ${OUT}/blank)
run(0 blank_render render --config ${CONFIG} --count 1 --output ${OUT}/one)
foreach(i RANGE 1 10)
  configure_file(${OUT}/one/000000.png ${OUT}/blank/b${i}.png COPYONLY)
endforeach()
run(1 blank calibrate ${OUT}/blank --height-m 2.0 --output ${OUT}/blank.json)
if(EXISTS ${OUT}/blank.json)
  message(FATAL_ERROR "lane calibrate wrote a config from ten copies of one frame")
endif()
# No height: a usage error.
run(2 noheight calibrate ${OUT}/frames --output ${OUT}/x.json)
run(2 badpp calibrate ${OUT}/frames --height-m 1.5 --principal-point 3 --output ${OUT}/x.json)
