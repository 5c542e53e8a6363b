# ctest driver: write a log with every liloc type (liloc_log sample), then decode it
# with the types jar the way lcm-spy does.
file(GLOB lcm_files ${CMAKE_CURRENT_LIST_DIR}/../../lcmtypes/*.lcm)
list(LENGTH lcm_files expected_types)
set(log ${WORK_DIR}/spy_check_sample.lcmlog)
execute_process(COMMAND ${LILOC_LOG} sample ${log} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "liloc_log sample failed")
endif()
execute_process(COMMAND ${JAVA} -cp ${CLASSPATH} ${CHECKER} ${log} ${expected_types}
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the types jar did not decode every message of ${log}")
endif()
