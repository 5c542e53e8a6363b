cmake_minimum_required(VERSION 3.22)
# `liloc_map build --poses` end to end: a short simulated drive mapped with its truth as the
# reference trajectory (an RTK/INS in the field) must give a map whose keyframes are the
# reference's (ATE 0.000 m), and a reference that covers only part of the drive must leave
# the other keyframes out and say so. LILOC_SIM, LILOC_MAP: the tools; WORK_DIR: scratch.
set(dir ${WORK_DIR}/build_with_reference_poses)
file(REMOVE_RECURSE ${dir})
execute_process(COMMAND ${LILOC_SIM} --out ${dir}/sim --lidar vlp16 --sessions A
                        --length-scale 0.05 --log-level warn
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "liloc_sim failed (exit ${rc})")
endif()
set(session ${dir}/sim/campus/vlp16/A)

execute_process(COMMAND ${LILOC_MAP} build ${session}/session.lcmlog ${dir}/map
                        --poses ${session}/ground_truth.tum
                        --ground-truth ${session}/ground_truth.tum --log-level warn
                OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
message("${out}${err}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "liloc_map build --poses failed (exit ${rc})")
endif()
if(NOT out MATCHES "loop closures +0\n")
  message(FATAL_ERROR "with reference poses no loop is to be closed")
endif()
if(NOT out MATCHES ", 0\\.000 m map")
  message(FATAL_ERROR "the map's keyframes are not the reference's")
endif()

# The reference's first half only: the rest of the keyframes are left out, with a warning.
file(STRINGS ${session}/ground_truth.tum lines)
list(LENGTH lines count)
math(EXPR half "${count} / 2")
list(SUBLIST lines 0 ${half} first_half)
list(JOIN first_half "\n" text)
file(WRITE ${dir}/half.tum "${text}\n")
execute_process(COMMAND ${LILOC_MAP} build ${session}/session.lcmlog ${dir}/map_half
                        --poses ${dir}/half.tum --log-level warn
                OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
message("${out}${err}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "liloc_map build --poses with half a reference failed (exit ${rc})")
endif()
if(NOT "${out}${err}" MATCHES "[0-9]+ of [0-9]+ keyframes left out: .*half\\.tum has no poses")
  message(FATAL_ERROR "the keyframes outside the reference were not named")
endif()
