# `lane calibrate --pitch-deg --yaw-deg` end to end (a camera of known
# mounting, docs/calibration.md): a few frames rendered through a wide-angle
# camera with a hood that rises towards the image's centre give a config
# whose top view starts beside the hood and reaches a dash cycle (12 m)
# beyond its middle; without a hood, the view a camera-only config gets;
# a wrong mounting is refused by the self-check.
include(${CMAKE_CURRENT_LIST_DIR}/cli_test_common.cmake)

file(WRITE ${OUT}/hood_camera.json
     "{\"camera\": {\"fu\": 500, \"fv\": 500, \"cu\": 410, \"cv\": 147.5, \"pitch_deg\": 2.5, "
     "\"yaw_deg\": 0, \"height_m\": 1.5, \"image_width\": 820, \"image_height\": 295}}\n")
set(MOUNT --pitch-deg 2.5 --yaw-deg 0 --focal-px 500 --principal-point 410,147.5 --height-m 1.5)

# The hood: row 209 (9 m ahead) at the centre, row 266 (5.3 m) at the sides.
run(0 render render --config ${OUT}/hood_camera.json --count 10 --seed 11 --hood-top-row 209
    --hood-side-row 266 --output ${OUT}/hood)
run(0 mounted calibrate ${OUT}/hood ${MOUNT} --output ${OUT}/mounted.json
    --overlay ${OUT}/mounted.png)
expect_contains("${mounted_out}" "given: no vanishing point" "calibrate with a known mounting")
expect_contains("${mounted_out}" "self-check" "calibrate with a known mounting: the self-check")
if(NOT EXISTS ${OUT}/mounted.png)
  message(FATAL_ERROR "lane calibrate --overlay wrote no ${OUT}/mounted.png")
endif()
run(0 mounted_show config --config ${OUT}/mounted.json)
string(JSON pitch GET "${mounted_show_out}" camera pitch_deg)
string(JSON view GET "${mounted_show_out}" ipm view)
string(JSON near GET "${mounted_show_out}" ipm ground y_min_m)
string(JSON far GET "${mounted_show_out}" ipm ground y_max_m)
if(NOT pitch EQUAL 2.5 OR NOT view STREQUAL "ground")
  message(FATAL_ERROR "mounted config: pitch ${pitch}, view ${view}: expected 2.5 and ground")
endif()
# Near: beside the hood, 5.4-6 m; far: the middle's 9 m plus 12 m.
if(near LESS 5.0 OR near GREATER 6.2 OR far LESS 20.4 OR far GREATER 21.8)
  message(FATAL_ERROR "mounted config's view ${near}..${far} m: expected about 5.6..21.2 m\n"
                      "${mounted_out}")
endif()

# No hood: the view is the one a config that gives only the camera gets.
run(0 plain_render render --config ${OUT}/hood_camera.json --count 10 --seed 11
    --output ${OUT}/plain)
run(0 plain calibrate ${OUT}/plain ${MOUNT} --output ${OUT}/plain.json)
run(0 plain_show config --config ${OUT}/plain.json)
run(0 camera_only_show config --config ${OUT}/hood_camera.json)
foreach(key x_min_m x_max_m y_min_m y_max_m)
  string(JSON written GET "${plain_show_out}" ipm ground ${key})
  string(JSON built_in GET "${camera_only_show_out}" ipm ground ${key})
  if(NOT written STREQUAL built_in)
    message(FATAL_ERROR "ipm.ground.${key}: lane calibrate wrote ${written}, a camera-only "
                        "config gets ${built_in}")
  endif()
endforeach()

# A mounting 3 degrees off in pitch: the lanes fan out on the ground.
run(1 wrong calibrate ${OUT}/plain --pitch-deg 5.5 --yaw-deg 0 --focal-px 500
    --principal-point 410,147.5 --height-m 1.5 --output ${OUT}/wrong.json)
expect_contains("${wrong_err}" "failed its self-check" "calibrate with a wrong mounting")
if(EXISTS ${OUT}/wrong.json)
  message(FATAL_ERROR "lane calibrate wrote a config for a mounting that failed its self-check")
endif()
# Pitch without yaw: a usage error.
run(2 halfmount calibrate ${OUT}/plain --pitch-deg 2.5 --height-m 1.5 --output ${OUT}/x.json)
