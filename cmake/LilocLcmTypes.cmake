# Generates C++ headers and a Java jar (for lcm-spy) from the *.lcm files of a folder.
#
# Target liloc_lcmtypes: interface library with the generated headers, post-processed by
# postprocess_lcmtypes.cmake: decoders hardened against corrupt lengths, and
# liloc/all_types.hpp listing every type.
# Target liloc_lcmtypes_jar: ${LILOC_TYPES_JAR}, the generated Java classes.

set(LILOC_LCM_POSTPROCESS_SCRIPT ${CMAKE_CURRENT_LIST_DIR}/postprocess_lcmtypes.cmake)

function(liloc_add_lcmtypes lcm_dir)
  file(GLOB lcm_files CONFIGURE_DEPENDS ${lcm_dir}/*.lcm)
  set(gen_dir ${CMAKE_BINARY_DIR}/lcmtypes)
  set(cpp_dir ${gen_dir}/cpp)
  set(stamp ${gen_dir}/cpp.stamp)

  add_custom_command(
    OUTPUT ${stamp}
    COMMAND ${CMAKE_COMMAND} -E remove_directory ${cpp_dir}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${cpp_dir}
    COMMAND ${LCM_GEN} --cpp --cpp-hpath ${cpp_dir} ${lcm_files}
    COMMAND ${CMAKE_COMMAND} -DDIR=${cpp_dir}/liloc -P ${LILOC_LCM_POSTPROCESS_SCRIPT}
    COMMAND ${CMAKE_COMMAND} -E touch ${stamp}
    DEPENDS ${lcm_files} ${LILOC_LCM_POSTPROCESS_SCRIPT}
    COMMENT "lcm-gen: C++ types"
    VERBATIM)
  add_custom_target(liloc_lcmtypes_gen DEPENDS ${stamp})

  add_library(liloc_lcmtypes INTERFACE)
  add_dependencies(liloc_lcmtypes liloc_lcmtypes_gen)
  # SYSTEM: generated code is not ours to keep warning-free.
  target_include_directories(liloc_lcmtypes SYSTEM INTERFACE ${cpp_dir})
  target_link_libraries(liloc_lcmtypes INTERFACE PkgConfig::LCM)

  find_package(Java COMPONENTS Development)
  find_file(LCM_JAR lcm.jar PATHS /usr/share/java /usr/local/share/java)
  if(NOT Java_JAVAC_EXECUTABLE OR NOT Java_JAR_EXECUTABLE OR NOT LCM_JAR)
    message(FATAL_ERROR "javac, jar and lcm.jar are needed for the lcm-spy types jar: run scripts/setup.sh")
  endif()
  set(java_dir ${gen_dir}/java)
  set(jar ${gen_dir}/liloc_types.jar)
  add_custom_command(
    OUTPUT ${jar}
    COMMAND ${CMAKE_COMMAND} -E remove_directory ${java_dir}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${java_dir}/src ${java_dir}/classes
    COMMAND ${LCM_GEN} --java --jpath ${java_dir}/src ${lcm_files}
    COMMAND ${CMAKE_COMMAND} -DSRC=${java_dir}/src -DCLASSES=${java_dir}/classes
            -DJAVAC=${Java_JAVAC_EXECUTABLE} -DLCM_JAR=${LCM_JAR}
            -P ${CMAKE_CURRENT_FUNCTION_LIST_DIR}/compile_java_types.cmake
    COMMAND ${Java_JAR_EXECUTABLE} cf ${jar} -C ${java_dir}/classes .
    DEPENDS ${lcm_files} ${CMAKE_CURRENT_FUNCTION_LIST_DIR}/compile_java_types.cmake
    COMMENT "lcm-gen: Java types jar for lcm-spy"
    VERBATIM)
  add_custom_target(liloc_lcmtypes_jar ALL DEPENDS ${jar})
  set(LILOC_TYPES_JAR ${jar} PARENT_SCOPE)
  set(LILOC_LCM_JAR ${LCM_JAR} PARENT_SCOPE)
endfunction()
