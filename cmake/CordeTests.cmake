# corde_sim build module: tests (included by the top-level CMakeLists.txt).

# Tests (only when testing is enabled). Test executables are not part of `all`: the `tests`
# target builds them, as catkin_add_gtest does (`catkin_make tests`; `catkin_make run_tests`
# builds and runs them). `make build`/`make test` build `all` and `tests`, then ctest runs every
# test: one ctest test per TEST() of the unit tests (a missing corde_unit_tests executable shows
# up as the failing test corde_unit_tests_NOT_BUILT, it is never skipped silently), the ROS-free
# guard, the benchmark smoke run and the rostests.
# ---------------------------------------------------------------------------------------------
if(CATKIN_ENABLE_TESTING)
  enable_testing()
  include(GoogleTest)
  if(NOT TARGET tests)
    add_custom_target(tests)
  endif()
  if(NOT TARGET GTest::gtest_main)
    find_package(GTest QUIET)
  endif()

  # catkin's run_tests: like catkin_run_tests_target() (run the command through catkin's
  # run_tests.py, which checks that it wrote its JUnit result for catkin_test_results), but
  # without the ctest entry that function also adds: ctest runs the unit tests per TEST().
  function(corde_catkin_run_tests name dependency)
    if(NOT TARGET run_tests_${PROJECT_NAME})
      add_custom_target(run_tests_${PROJECT_NAME})
      add_custom_target(_run_tests_${PROJECT_NAME})
      add_dependencies(run_tests _run_tests_${PROJECT_NAME})
    endif()
    if(NOT TARGET clean_test_results_${PROJECT_NAME})
      add_custom_target(clean_test_results_${PROJECT_NAME}
        COMMAND ${PYTHON_EXECUTABLE} ${catkin_EXTRAS_DIR}/test/remove_test_results.py
                ${CATKIN_TEST_RESULTS_DIR}/${PROJECT_NAME}
        VERBATIM)
    endif()
    add_custom_target(run_tests_${PROJECT_NAME}_${name} COMMAND ${ARGN} VERBATIM)
    add_dependencies(run_tests_${PROJECT_NAME}_${name} ${dependency})
    add_dependencies(run_tests_${PROJECT_NAME} run_tests_${PROJECT_NAME}_${name})
    add_custom_target(_run_tests_${PROJECT_NAME}_${name} COMMAND ${ARGN} VERBATIM)
    add_dependencies(_run_tests_${PROJECT_NAME}_${name}
      clean_test_results_${PROJECT_NAME} tests ${dependency})
    add_dependencies(_run_tests_${PROJECT_NAME} _run_tests_${PROJECT_NAME}_${name})
  endfunction()

  # Two gtest executables: unit tests (test/unit/<folder>, mirroring src/core) and validation
  # tests against analytic references (test/validation). Shared helpers live in test/support.
  # Each TEST() becomes one ctest test, labelled `unit` or `validation` (ctest -L unit).
  if(NOT TARGET GTest::gtest_main)
    message(WARNING "${PROJECT_NAME}: GoogleTest not found, unit tests are not built")
  endif()
  foreach(kind unit validation)
    file(GLOB_RECURSE _sources CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/test/${kind}/*.cpp)
    if(NOT _sources OR NOT TARGET GTest::gtest_main)
      continue()
    endif()
    set(_exe corde_${kind}_tests)
    add_executable(${_exe} EXCLUDE_FROM_ALL ${_sources})
    add_dependencies(tests ${_exe})
    target_link_libraries(${_exe} PRIVATE corde_core GTest::gtest_main)
    target_include_directories(${_exe} PRIVATE ${PROJECT_SOURCE_DIR}/test/support
                                               ${PROJECT_SOURCE_DIR}/src/tools)
    target_compile_definitions(${_exe} PRIVATE CORDE_SIM_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
    if(TARGET corde_run)
      # corde_run_test runs the tool itself for its exit statuses and messages.
      add_dependencies(${_exe} corde_run)
      target_compile_definitions(${_exe} PRIVATE CORDE_RUN_BINARY="$<TARGET_FILE:corde_run>")
    endif()
    if(kind STREQUAL "unit" AND TARGET corde_ros)
      # The adapter's ROS-free logic (~configure's checks against the key ranges) is tested here
      # too, when the adapter is built.
      corde_ros_target(${_exe})
      target_link_libraries(${_exe} PRIVATE corde_ros)
      target_compile_definitions(${_exe} PRIVATE CORDE_TEST_ROS_ADAPTER=1)
    endif()
    set_target_properties(${_exe} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR})
    # Run from the source root (config/ paths work). Suites whose tests share one expensive run
    # (a function-local static) run as one ctest test, so that the run is computed once.
    set(_shared)
    if(kind STREQUAL "validation")
      set(_shared OverhandKnot PlectonemeContact)
    endif()
    set(_filter "*")
    if(_shared)
      list(JOIN _shared ".*:" _joined)
      set(_filter "-${_joined}.*")
    endif()
    gtest_discover_tests(${_exe}
      WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
      DISCOVERY_TIMEOUT 60
      NO_PRETTY_VALUES
      TEST_FILTER ${_filter}
      PROPERTIES LABELS ${kind})
    foreach(_suite ${_shared})
      add_test(NAME ${_suite}.all COMMAND ${_exe} --gtest_filter=${_suite}.*
        WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})
      set_tests_properties(${_suite}.all PROPERTIES LABELS ${kind})
    endforeach()
    if(catkin_FOUND)
      set(_xml ${CATKIN_TEST_RESULTS_DIR}/${PROJECT_NAME}/gtest-${_exe}.xml)
      corde_catkin_run_tests(gtest_${_exe} ${_exe}
        ${CATKIN_ENV} ${PYTHON_EXECUTABLE} ${catkin_EXTRAS_DIR}/test/run_tests.py ${_xml}
        --working-dir ${PROJECT_SOURCE_DIR}
        "$<TARGET_FILE:${_exe}> --gtest_output=xml:${_xml}")
    endif()
  endforeach()

  # Guard: the library's sources and headers include no ROS header (on Debian the ROS headers
  # sit in /usr/include, so a stray include would otherwise compile silently).
  add_test(NAME corde_core_is_ros_free
    COMMAND sh -c "! grep -rnE '#[[:space:]]*include[[:space:]]*[<\"](ros/|tf2|tf2_ros/|[a-z_]*_msgs/|std_srvs/|diagnostic_updater/|interactive_markers/|dynamic_reconfigure/|${PROJECT_NAME}/ros/|${PROJECT_NAME}/[A-Z])' src/core include/${PROJECT_NAME} --include=*.h --include=*.hpp --include=*.cpp --exclude-dir=ros"
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})

  # Formatting: every C++ file as clang-format (.clang-format) would write it (`make format`).
  find_program(CORDE_CLANG_FORMAT clang-format)
  if(CORDE_CLANG_FORMAT)
    add_test(NAME format_check
      COMMAND sh -c "find src include test \\( -name '*.cpp' -o -name '*.h' \\) -print0 | xargs -0 ${CORDE_CLANG_FORMAT} --dry-run -Werror"
      WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})
  else()
    add_test(NAME format_check
      COMMAND sh -c "echo 'clang-format is not installed (apt-get install clang-format)'; exit 1")
  endif()
  set_tests_properties(corde_core_is_ros_free format_check PROPERTIES LABELS checks)

  # catkin_lint (1-2 s, offline): CMakeLists.txt and package.xml stay free of errors, warnings
  # and notices. The checkout's folder name need not be the package name.
  find_program(CORDE_CATKIN_LINT catkin_lint)
  if(CORDE_CATKIN_LINT)
    add_test(NAME catkin_lint
      COMMAND ${CORDE_CATKIN_LINT} -W2 --strict --offline -q --ignore package_path_name
              ${PROJECT_SOURCE_DIR})
  else()
    add_test(NAME catkin_lint
      COMMAND sh -c "echo 'catkin_lint is not installed (apt-get install catkin-lint)'; exit 1")
  endif()
  set_tests_properties(catkin_lint PROPERTIES LABELS checks)

  # Smoke run so that the tests exercise the benchmark code; no timing is checked.
  # (libbenchmark 1.7 takes --benchmark_min_time in seconds, without a unit suffix.)
  if(TARGET corde_bench)
    add_test(NAME corde_bench_short COMMAND corde_bench --benchmark_min_time=0.01)
    set_tests_properties(corde_bench_short PROPERTIES LABELS tools)
  endif()

  # The charts' code keeps working: corde_charts --short into a temporary folder, its CSV checked
  # (columns, rows, sane values) and drawn by scripts/plot_charts.py (needs python3-matplotlib).
  if(TARGET corde_charts)
    add_test(NAME corde_charts_short
      COMMAND ${PYTHON_EXECUTABLE} ${PROJECT_SOURCE_DIR}/test/charts/charts_short_check.py
              $<TARGET_FILE:corde_charts> ${PROJECT_SOURCE_DIR})
    set_tests_properties(corde_charts_short PROPERTIES LABELS tools)
  endif()

  # The Python package (test/python, label python): the API against corde_run, and the batch
  # engine on a local Dask cluster. PYTHONPATH points at the built package (CordePython.cmake).
  if(CORDE_PYTHON_TARGET AND TARGET corde_run)
    foreach(_py api_test batch_test)
      if(EXISTS "${PROJECT_SOURCE_DIR}/test/python/${_py}.py")
        add_test(NAME python_${_py}
          COMMAND ${PYTHON_EXECUTABLE} ${PROJECT_SOURCE_DIR}/test/python/${_py}.py
          WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})
        set_tests_properties(python_${_py} PROPERTIES LABELS python TIMEOUT 300
          ENVIRONMENT "PYTHONPATH=${CORDE_PYTHON_PATH};CORDE_RUN=$<TARGET_FILE:corde_run>")
      endif()
    endforeach()
  endif()

  # The libFuzzer targets, the scene reader's and the URDF reader's (test/fuzz/README.md).
  # libFuzzer needs clang while this build may use g++, so the script compiles them with clang++
  # itself (`tests` builds them); each test fuzzes for 20 s and is skipped (exit 77) when no
  # clang++ supports -fsanitize=fuzzer. Only with CORDE_FUZZ (CordeSettings.cmake).
  if(CORDE_FUZZ)
    set(CORDE_FUZZ_SCRIPT ${PROJECT_SOURCE_DIR}/test/fuzz/run_fuzz_short.sh)
    foreach(target scene urdf)
      add_custom_target(${PROJECT_NAME}_${target}_fuzz
        COMMAND bash ${CORDE_FUZZ_SCRIPT} ${target} ${PROJECT_SOURCE_DIR}
                ${PROJECT_BINARY_DIR}/fuzz_${target} --build
        VERBATIM)
      add_dependencies(tests ${PROJECT_NAME}_${target}_fuzz)
      add_test(NAME ${target}_fuzz_short
        COMMAND bash ${CORDE_FUZZ_SCRIPT} ${target} ${PROJECT_SOURCE_DIR}
                ${PROJECT_BINARY_DIR}/fuzz_${target} 20)
      set_tests_properties(${target}_fuzz_short PROPERTIES SKIP_RETURN_CODE 77 TIMEOUT 600
        LABELS fuzz)
    endforeach()
  endif()

  if(catkin_FOUND AND CORDE_ROSTEST_FILES)
    find_package(rostest REQUIRED)
    # Helper test nodes: each test/ros/<name>.cpp becomes the executable <name> in
    # devel/lib/corde_sim (use it as <test pkg="corde_sim" type="<name>">), built by `tests`.
    # It writes its own main (ros::init, then RUN_ALL_TESTS) and is linked with gtest (not
    # gtest_main).
    set(CORDE_ROSTEST_TARGETS)
    foreach(src ${CORDE_ROSTEST_SOURCES})
      get_filename_component(name ${src} NAME_WE)
      add_executable(${name} EXCLUDE_FROM_ALL ${src})
      add_dependencies(tests ${name})
      if(TARGET corde_ros)
        target_link_libraries(${name} PRIVATE corde_ros)
      endif()
      corde_ros_target(${name})
      target_link_libraries(${name} PRIVATE GTest::gtest)
      list(APPEND CORDE_ROSTEST_TARGETS ${name})
    endforeach()
    # The rostests also run the nodes and Python test nodes, which import the generated Python
    # messages: `catkin_make run_tests` builds those too, even without a `catkin_make` first.
    list(APPEND CORDE_ROSTEST_TARGETS ${CORDE_NODE_TARGETS})
    if(CORDE_HAS_MESSAGES)
      list(APPEND CORDE_ROSTEST_TARGETS ${PROJECT_NAME}_generate_messages_py)
    endif()
    if(CORDE_HAS_CFG)
      list(APPEND CORDE_ROSTEST_TARGETS ${PROJECT_NAME}_gencfg)
    endif()
    foreach(launch ${CORDE_ROSTEST_FILES})
      if(CORDE_ROSTEST_TARGETS)
        add_rostest(${launch} DEPENDENCIES ${CORDE_ROSTEST_TARGETS})
      else()
        add_rostest(${launch})
      endif()
    endforeach()
    # catkin names rostests _ctest_<package>_rostest_<path>; label them `ros`.
    get_property(_all_tests DIRECTORY PROPERTY TESTS)
    foreach(_t ${_all_tests})
      if(_t MATCHES "^_ctest_${PROJECT_NAME}_rostest_")
        set_tests_properties(${_t} PROPERTIES LABELS ros)
      endif()
    endforeach()
  endif()
elseif(PROJECT_SOURCE_DIR STREQUAL CMAKE_SOURCE_DIR AND NOT TARGET tests)
  # Testing off in a build of this package alone: an empty `tests` keeps `make build` working.
  add_custom_target(tests)
endif()

