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

# liloc_module(<name> SOURCES ... DEPS ...): one static library per folder under common/.
function(liloc_module name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_library(liloc_${name} STATIC ${ARG_SOURCES})
  target_include_directories(liloc_${name} PUBLIC ${PROJECT_SOURCE_DIR}/common)
  target_link_libraries(liloc_${name} PUBLIC ${ARG_DEPS} PRIVATE liloc_warnings)
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
