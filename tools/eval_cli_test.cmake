# End-to-end test of `lane eval`, run by ctest as
#   cmake -DLANE=<lane binary> -DSRC=<source dir> -DOUT=<scratch dir> -P eval_cli_test.cmake
# Renders a few synthetic frames, evaluates the detector on them, then scores
# the results it wrote (JSON Lines and the original .txt format) and expects
# the same tables.
include(${CMAKE_CURRENT_LIST_DIR}/cli_test_common.cmake)

# The two "| Total | ..." rows of a table (paper rule, CULane).
function(total_rows text out)
  string(REGEX MATCHALL "\\| Total \\|[^\n]*" rows "${text}")
  set(${out} "${rows}" PARENT_SCOPE)
endfunction()

# --- usage -------------------------------------------------------------------
run(0 help eval --help)
expect_contains("${help_out}" "--results" "lane eval --help")
run(0 top_help --help)
expect_contains("${top_help_out}" "eval" "lane --help")
run(2 no_dataset eval --config "${CONFIG}")
expect_contains("${no_dataset_err}" "no DATASET" "lane eval without a data set")
run(2 no_source eval "${OUT}")
expect_contains("${no_source_err}" "--config" "lane eval without --config or --results")
run(2 bad_rule eval --config "${CONFIG}" --rule xor "${OUT}")
run(1 missing eval --config "${CONFIG}" "${OUT}/no-such-folder")
expect_contains("${missing_err}" "no such folder" "lane eval on a missing folder")
run(1 not_a_dataset eval --config "${CONFIG}" "${OUT}")
expect_contains("${not_a_dataset_err}" "cannot tell the format" "lane eval on an empty folder")

# --- detector run ------------------------------------------------------------
run(0 render render --config "${CONFIG}" --count 4 --seed 3 --num-lanes 2 --output "${OUT}/frames")
run(0 eval eval --config "${CONFIG}" --output "${OUT}/eval" --overlay "${OUT}/eval/overlays"
    --write-baseline "${OUT}/baseline.json" "${OUT}/frames")
expect_contains("${eval_out}" "## Paper rule" "lane eval tables")
expect_contains("${eval_out}" "## CULane metric" "lane eval tables")
expect_contains("${eval_out}" "| Total | 4 |" "lane eval tables")
expect_contains("${eval_err}" "CULane F1" "lane eval summary")
foreach(f table.md table.json results.jsonl results.txt frames.jsonl overlays/000000.png overlays/000003.png)
  if(NOT EXISTS "${OUT}/eval/${f}")
    message(FATAL_ERROR "lane eval --output/--overlay did not write ${f}")
  endif()
endforeach()
file(READ "${OUT}/baseline.json" baseline)
expect_contains("${baseline}" "\"culane_f1\"" "--write-baseline")
expect_contains("${baseline}" "--write-baseline" "--write-baseline records its command")
file(READ "${OUT}/eval/table.json" table_json)
expect_contains("${table_json}" "\"correct_rate\"" "table.json")
file(STRINGS "${OUT}/eval/results.jsonl" jsonl_lines)
list(LENGTH jsonl_lines n)
if(NOT n EQUAL 4)
  message(FATAL_ERROR "results.jsonl has ${n} lines, expected 4")
endif()
total_rows("${eval_out}" detector_rows)

# frames.jsonl: a line per frame, and its per-detection matches add up to the
# table's false positives and correct labels.
file(STRINGS "${OUT}/eval/frames.jsonl" match_lines)
list(LENGTH match_lines n)
if(NOT n EQUAL 4)
  message(FATAL_ERROR "frames.jsonl has ${n} lines, expected 4")
endif()
set(fp_sum 0)
set(found_sum 0)
foreach(line IN LISTS match_lines)
  foreach(key detection_label label_detection)
    string(JSON len LENGTH "${line}" paper ${key})
    if(len GREATER 0)
      math(EXPR last "${len} - 1")
      foreach(i RANGE ${last})
        string(JSON v GET "${line}" paper ${key} ${i})
        if(key STREQUAL "detection_label" AND v EQUAL -1)
          math(EXPR fp_sum "${fp_sum} + 1")
        elseif(key STREQUAL "label_detection" AND NOT v EQUAL -1)
          math(EXPR found_sum "${found_sum} + 1")
        endif()
      endforeach()
    endif()
  endforeach()
endforeach()
string(JSON table_fp GET "${table_json}" total paper false_positives)
string(JSON table_correct GET "${table_json}" total paper correct)
if(NOT fp_sum EQUAL table_fp OR NOT found_sum EQUAL table_correct)
  message(FATAL_ERROR "frames.jsonl counts ${fp_sum} false positives and ${found_sum} labels "
                      "found; table.json: ${table_fp} and ${table_correct}")
endif()

# --- scoring the written results gives the same tables ---------------------
run(0 jsonl eval --results "${OUT}/eval/results.jsonl" "${OUT}/frames")
total_rows("${jsonl_out}" jsonl_rows)
if(NOT "${jsonl_rows}" STREQUAL "${detector_rows}")
  message(FATAL_ERROR "scoring results.jsonl gave\n${jsonl_rows}\ninstead of\n${detector_rows}")
endif()
run(0 txt eval --results "${OUT}/eval/results.txt" --config "${CONFIG}" "${OUT}/frames")
total_rows("${txt_out}" txt_rows)
if(NOT "${txt_rows}" STREQUAL "${detector_rows}")
  message(FATAL_ERROR "scoring results.txt gave\n${txt_rows}\ninstead of\n${detector_rows}")
endif()
run(2 seed_with_results eval --results "${OUT}/eval/results.txt" --seed 3 "${OUT}/frames")
# The old spellings --out and --overlays are aliases of --output and --overlay.
run(0 old_names eval --config "${CONFIG}" --out "${OUT}/eval-old"
    --overlays "${OUT}/eval-old/overlays" "${OUT}/frames")
foreach(f table.md results.txt overlays/000000.png)
  if(NOT EXISTS "${OUT}/eval-old/${f}")
    message(FATAL_ERROR "lane eval --out/--overlays did not write ${f}")
  endif()
endforeach()
run(2 seeds_with_results eval --results "${OUT}/eval/results.txt" --seeds 3 "${OUT}/frames")

# --- --results with --out writes the tables (it used to fail with "error
# writing to DIR": closing the never-opened results.jsonl set its failbit) ---
file(REMOVE_RECURSE "${OUT}/rescored")
run(0 rescored eval --results "${OUT}/eval/results.jsonl" --out "${OUT}/rescored" "${OUT}/frames")
foreach(f table.md table.json results.txt)
  if(NOT EXISTS "${OUT}/rescored/${f}")
    message(FATAL_ERROR "lane eval --results --out did not write ${f}:\n${rescored_err}")
  endif()
endforeach()
string(FIND "${rescored_err}" "error writing" _pos)
if(NOT _pos EQUAL -1)
  message(FATAL_ERROR "lane eval --results --out reported:\n${rescored_err}")
endif()

# --- labels copied from frame to frame: warned, and skipped on request -------
# A CULane folder of three rendered frames whose last two label files are the
# same: one repeat, warned about; --skip-repeated-labels scores two frames.
file(MAKE_DIRECTORY "${OUT}/copied")
file(COPY_FILE "${OUT}/frames/000000.png" "${OUT}/copied/00000.png")
file(COPY_FILE "${OUT}/frames/000001.png" "${OUT}/copied/00090.png")
file(COPY_FILE "${OUT}/frames/000002.png" "${OUT}/copied/00180.png")
file(WRITE "${OUT}/copied/00000.lines.txt" "100 479 300 260\n540 479 340 260\n")
file(WRITE "${OUT}/copied/00090.lines.txt" "110 479 305 260\n530 479 335 260\n")
file(WRITE "${OUT}/copied/00180.lines.txt" "110 479 305 260\n530 479 335 260\n")
run(0 copied eval --config "${CONFIG}" "${OUT}/copied")
expect_contains("${copied_err}" "1 of 3 labelled frames repeat" "lane eval on copied labels")
expect_contains("${copied_err}" "3 frames scored" "lane eval on copied labels")
run(0 copied_skip eval --config "${CONFIG}" --skip-repeated-labels "${OUT}/copied")
expect_contains("${copied_skip_err}" "2 frames scored" "lane eval --skip-repeated-labels")
run(2 copied_drive eval --config "${CONFIG}" --drive --skip-repeated-labels "${OUT}/copied")

# --- several seeds: mean and spread, the first seed's tables unchanged -------
run(0 seeds eval --config "${CONFIG}" --seeds 3 --out "${OUT}/seeds"
    --write-baseline "${OUT}/seeds-baseline.json" "${OUT}/frames")
expect_contains("${seeds_out}" "## Over 3 RANSAC seeds (1, 2, 3)" "lane eval --seeds")
expect_contains("${seeds_err}" "over 3 seeds" "lane eval --seeds summary")
total_rows("${seeds_out}" seeds_rows)
list(LENGTH seeds_rows n_rows)
if(NOT n_rows EQUAL 3)
  message(FATAL_ERROR "lane eval --seeds: expected 3 Total rows (spread, paper, CULane), got:\n${seeds_rows}")
endif()
list(SUBLIST seeds_rows 1 2 seeds_first)
if(NOT "${seeds_first}" STREQUAL "${detector_rows}")
  message(FATAL_ERROR "lane eval --seeds: the first seed's tables\n${seeds_first}\ndiffer from a single run's\n${detector_rows}")
endif()
file(READ "${OUT}/seeds/table.json" seeds_json)
expect_contains("${seeds_json}" "\"seeds\"" "table.json with --seeds")
file(READ "${OUT}/seeds-baseline.json" seeds_baseline)
expect_contains("${seeds_baseline}" "\"seeds\"" "baseline with --seeds")
run(2 zero_seeds eval --config "${CONFIG}" --seeds 0 "${OUT}/frames")

# --- 2-lanes mode and the original counting ----------------------------------
run(0 two eval --config "${CONFIG}" --mode two --count many-to-one --rule or "${OUT}/frames")
expect_contains("${two_out}" "mode two" "lane eval --mode two")
expect_contains("${two_out}" "ego lane" "lane eval --mode two")
expect_contains("${two_out}" "many-to-one" "lane eval --count many-to-one")

# --- a broken results file names the file and line -------------------------
file(WRITE "${OUT}/broken.jsonl" "{\"schema\":1,\"frame\":\"000000.png\",\"lanes\":[]}\nnot json\n")
run(1 broken eval --results "${OUT}/broken.jsonl" "${OUT}/frames")
expect_contains("${broken_err}" "broken.jsonl:2: not a JSON object" "a malformed results file")

# --- a drive (--drive): tracked against untracked, and a tracked results file
run(0 drive_render render --config "${CONFIG}" --sequence --count 45 --seed 7
    --output "${OUT}/drive")
run(0 drive eval --drive --config "${CONFIG}" "${OUT}/drive")
expect_contains("${drive_out}" "| | untracked | tracked (confirmed lanes) |" "lane eval --drive")
expect_contains("${drive_out}" "| frames | 45 | 45 |" "lane eval --drive")
expect_contains("${drive_out}" "| id switches per 100 boundary-frames |" "lane eval --drive")
expect_contains("${drive_err}" "drive of 45 frames" "lane eval --drive summary")
# The tracked column's rows, and those of `lane detect --track`'s results
# scored alone: the same tracker on the same frames at the same times.
function(drive_rows text column out)
  string(REGEX MATCHALL "\n\\| [a-z][^|\n]* \\|[^\n]*" rows "${text}")
  set(kept "")
  foreach(r IN LISTS rows)
    string(REGEX REPLACE "^\n\\| ([^|]*) \\|.*" "\\1" name "${r}")
    string(REGEX MATCH "\\| ([^|]*) \\|$" _ "${r}")
    list(APPEND kept "${name}:${CMAKE_MATCH_1}")
  endforeach()
  set(${out} "${kept}" PARENT_SCOPE)
endfunction()
run(0 drive_detect detect --config "${CONFIG}" --track -q --output "${OUT}/drive.jsonl"
    "${OUT}/drive")
run(0 drive_results eval --drive --results "${OUT}/drive.jsonl" "${OUT}/drive")
expect_contains("${drive_results_out}" "results (confirmed lanes)" "lane eval --drive --results")
drive_rows("${drive_out}" tracked config_rows)
drive_rows("${drive_results_out}" tracked results_rows)
if(NOT "${config_rows}" STREQUAL "${results_rows}")
  message(FATAL_ERROR "lane eval --drive: the tracked figures\n${config_rows}\ndiffer from lane "
                      "detect --track's results scored\n${results_rows}")
endif()
string(REGEX MATCH "\\| recall \\| [0-9.]+ \\| ([0-9.]+) \\|" _ "${drive_out}")
if(NOT CMAKE_MATCH_1 OR CMAKE_MATCH_1 LESS 0.3)
  message(FATAL_ERROR "lane eval --drive: tracked recall '${CMAKE_MATCH_1}' on a rendered drive")
endif()
run(2 drive_seeds eval --drive --config "${CONFIG}" --seeds 3 "${OUT}/drive")
run(1 drive_not_a_drive eval --drive --config "${CONFIG}" "${OUT}/frames")
expect_contains("${drive_not_a_drive_err}" "time_s" "lane eval --drive on frames that are no drive")
