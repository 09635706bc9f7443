# corde_sim build module: compiler settings and warnings (included by the top-level CMakeLists.txt).

if(NOT CMAKE_BUILD_TYPE AND NOT CMAKE_CONFIGURATION_TYPES)
  #catkin_lint: ignore_once global_var_collision
  set(CMAKE_BUILD_TYPE Release CACHE STRING "Build type" FORCE)
  set_property(CACHE CMAKE_BUILD_TYPE PROPERTY STRINGS Debug Release RelWithDebInfo MinSizeRel)
endif()
set(CMAKE_CXX_STANDARD 17)
set(CMAKE_CXX_STANDARD_REQUIRED ON)
set(CMAKE_CXX_EXTENSIONS OFF)
set(CMAKE_CXX_FLAGS_RELEASE "-O3 -DNDEBUG")  # portable: no -march=native
set(CMAKE_EXPORT_COMPILE_COMMANDS ON)
add_compile_options(-Wall -Wextra)

# Tests are configured when CATKIN_ENABLE_TESTING is on (catkin's switch, default ON; a build
# without ROS honours the same option, see below).
#catkin_lint: ignore_once global_var_collision
option(CORDE_WITH_ROS "Build the ROS adapter when catkin is found" ON)


# Warnings as errors where the build must stay clean (CI sets it: scripts via CORDE_WERROR=ON).
#catkin_lint: ignore_once global_var_collision
option(CORDE_WERROR "Treat compiler warnings as errors" OFF)

# The libFuzzer targets (test/fuzz/): clang++ compiles the library again with ASan and UBSan for
# them, about 20 minutes on 2 cores. Off by default, so that a catkin workspace's `tests` does
# not pay for them; the project's own `make build`/`make test` turn it on (Makefile CORDE_FUZZ).
#catkin_lint: ignore_once global_var_collision
option(CORDE_FUZZ "Build the libFuzzer targets with the tests and run them in ctest" OFF)
if(CORDE_WERROR)
  add_compile_options(-Werror)
endif()
