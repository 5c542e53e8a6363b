# Compiler settings and the target helpers every folder uses.

find_program(CCACHE_PROGRAM ccache)
if(CCACHE_PROGRAM)
  set(CMAKE_C_COMPILER_LAUNCHER ${CCACHE_PROGRAM})
  set(CMAKE_CXX_COMPILER_LAUNCHER ${CCACHE_PROGRAM})
endif()

# Release keeps assertions off but debug info small enough for backtraces.
set(CMAKE_CXX_FLAGS_RELEASE "-O2 -DNDEBUG")
set(CMAKE_CXX_FLAGS_RELWITHDEBINFO "-O2 -g -DNDEBUG")

add_library(liloc_warnings INTERFACE)
target_compile_options(liloc_warnings INTERFACE -Wall -Wextra -Wpedantic -Wshadow
                                                -Wnon-virtual-dtor -Wno-psabi)
if(LILOC_WERROR)
  target_compile_options(liloc_warnings INTERFACE -Werror)
endif()

# Layering: what each target declares, recorded for tests/check_layering.cmake. A target's
# files may include the headers of its own folder (`include_key`, the first component of
# an include path: "map" for common/map/) and of the folders of the liloc libraries it
# declares in DEPS, nothing else of liloc.
function(liloc_record_layering target include_key)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  set(deps "")
  foreach(dep ${ARG_DEPS})
    if(dep MATCHES "^liloc_")
      list(APPEND deps ${dep})
    endif()
  endforeach()
  set_property(GLOBAL APPEND PROPERTY LILOC_LAYERING_TARGETS ${target})
  set_property(GLOBAL PROPERTY LILOC_LAYERING_${target}_KEY "${include_key}")
  set_property(GLOBAL PROPERTY LILOC_LAYERING_${target}_DIR ${CMAKE_CURRENT_SOURCE_DIR})
  set_property(GLOBAL PROPERTY LILOC_LAYERING_${target}_SOURCES ${ARG_SOURCES})
  set_property(GLOBAL PROPERTY LILOC_LAYERING_${target}_DEPS "${deps}")
endfunction()

# Writes what liloc_record_layering gathered, once every folder was added.
function(liloc_write_layering file)
  get_property(targets GLOBAL PROPERTY LILOC_LAYERING_TARGETS)
  set(out "set(LILOC_TARGETS \"${targets}\")\n")
  foreach(t ${targets})
    foreach(field KEY DIR SOURCES DEPS)
      get_property(value GLOBAL PROPERTY LILOC_LAYERING_${t}_${field})
      string(APPEND out "set(${t}_${field} \"${value}\")\n")
    endforeach()
  endforeach()
  file(WRITE ${file} "${out}")
endfunction()

# liloc_module(<name> SOURCES ... DEPS ...): one static library per folder under common/
# (a folder may hold a few, e.g. bridge/ and bridge_pcl; the folder is the include key).
function(liloc_module name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_library(liloc_${name} STATIC ${ARG_SOURCES})
  target_include_directories(liloc_${name} PUBLIC ${PROJECT_SOURCE_DIR}/common)
  target_link_libraries(liloc_${name} PUBLIC ${ARG_DEPS} PRIVATE liloc_warnings)
  get_filename_component(folder ${CMAKE_CURRENT_SOURCE_DIR} NAME)
  liloc_record_layering(liloc_${name} ${folder} SOURCES ${ARG_SOURCES} DEPS ${ARG_DEPS})
endfunction()

# liloc_executable(<name> SOURCES ... DEPS ...): a process, tool or bench program, built
# as build/bin/<name>. The target is <name>_exe, because module libraries already use
# names like liloc_sim (common/sim) that tools share (tools/liloc_sim).
function(liloc_executable name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name}_exe ${ARG_SOURCES})
  set_target_properties(${name}_exe PROPERTIES OUTPUT_NAME ${name}
                                               RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/bin)
  target_include_directories(${name}_exe PRIVATE ${PROJECT_SOURCE_DIR}/tools)
  target_link_libraries(${name}_exe PRIVATE ${ARG_DEPS} liloc_warnings)
  # A tool includes its own folder's headers as "<tool>/x.hpp"; processes and benchmarks
  # have none.
  set(own "")
  get_filename_component(parent ${CMAKE_CURRENT_SOURCE_DIR} DIRECTORY)
  if(parent STREQUAL "${PROJECT_SOURCE_DIR}/tools")
    get_filename_component(own ${CMAKE_CURRENT_SOURCE_DIR} NAME)
  endif()
  liloc_record_layering(${name}_exe "${own}" SOURCES ${ARG_SOURCES} DEPS ${ARG_DEPS})
endfunction()

# The workplace's read-only real test data (../shared/data next to the checkout); set
# LILOC_SHARED_DATA_DIR when the checkout lives elsewhere. Tests that need it fail, naming
# the file, if it is missing.
if(NOT LILOC_SHARED_DATA_DIR)
  set(LILOC_SHARED_DATA_DIR "${PROJECT_SOURCE_DIR}/../shared/data")
  if(NOT EXISTS "${LILOC_SHARED_DATA_DIR}" AND EXISTS "/work/shared/data")
    set(LILOC_SHARED_DATA_DIR "/work/shared/data")
  endif()
endif()
set(LILOC_SHARED_DATA_DIR "${LILOC_SHARED_DATA_DIR}" CACHE PATH "real test data (../shared/data)")

# liloc_test(<module> DEPS ...): tests/test_<module>.cpp as one gtest binary, registered
# with ctest. Called from the module's own CMakeLists.txt, next to the library it tests.
function(liloc_test module)
  if(NOT LILOC_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "DEPS" ${ARGN})
  add_executable(test_${module} ${PROJECT_SOURCE_DIR}/tests/test_${module}.cpp)
  target_link_libraries(test_${module} PRIVATE ${ARG_DEPS} GTest::gtest_main liloc_warnings)
  target_compile_definitions(test_${module} PRIVATE
                             LILOC_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
                             LILOC_SHARED_DATA_DIR="${LILOC_SHARED_DATA_DIR}")
  set_target_properties(test_${module} PROPERTIES RUNTIME_OUTPUT_DIRECTORY
                                                  ${PROJECT_BINARY_DIR}/tests)
  gtest_discover_tests(test_${module} DISCOVERY_TIMEOUT 60 PROPERTIES TIMEOUT 600)
endfunction()

# Adds every immediate subfolder of the current folder that has a CMakeLists.txt, so that
# a new module, tool or process is one new folder and no edit elsewhere.
function(liloc_add_subfolders)
  file(GLOB children LIST_DIRECTORIES true ${CMAKE_CURRENT_SOURCE_DIR}/*)
  foreach(child ${children})
    if(EXISTS ${child}/CMakeLists.txt)
      add_subdirectory(${child})
    endif()
  endforeach()
endfunction()
