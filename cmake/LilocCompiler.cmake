# Compiler settings shared by every liloc target.

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

# liloc_executable(<name> SOURCES ... DEPS ...): a process, tool or bench program.
function(liloc_executable name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} liloc_warnings)
endfunction()
