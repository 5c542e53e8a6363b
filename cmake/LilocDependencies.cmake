# Third-party dependencies, all from Debian packages (see scripts/setup.sh).

find_package(Threads REQUIRED)
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(spdlog REQUIRED)
find_package(yaml-cpp REQUIRED)
find_package(PkgConfig REQUIRED)
# Debian's LCM ships no CMake package; pkg-config `lcm` needs libglib2.0-dev.
pkg_check_modules(LCM REQUIRED IMPORTED_TARGET lcm)
find_program(LCM_GEN lcm-gen REQUIRED)

if(LILOC_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
