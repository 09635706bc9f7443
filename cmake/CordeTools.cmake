# corde_sim build module: the command-line tools (included by the top-level CMakeLists.txt).

set(CORDE_TOOL_TARGETS)
foreach(tool corde_run corde_accuracy corde_charts)
  if(EXISTS "${PROJECT_SOURCE_DIR}/src/tools/${tool}.cpp")
    add_executable(${tool} src/tools/${tool}.cpp)
    target_link_libraries(${tool} PRIVATE corde_core)
    list(APPEND CORDE_TOOL_TARGETS ${tool})
  endif()
endforeach()
if(EXISTS "${PROJECT_SOURCE_DIR}/src/tools/corde_bench.cpp")
  find_package(benchmark QUIET)
  if(benchmark_FOUND)
    add_executable(corde_bench src/tools/corde_bench.cpp)
    target_link_libraries(corde_bench PRIVATE corde_core benchmark::benchmark)
    # BM_RodStack, BM_RopePile, BM_OverhandKnot, BM_PlectonemeContact and BM_GripperSweep read
    # shipped scenes.
    target_compile_definitions(corde_bench PRIVATE CORDE_SIM_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
    list(APPEND CORDE_TOOL_TARGETS corde_bench)
  else()
    message(WARNING "${PROJECT_NAME}: Google Benchmark not found, corde_bench is not built")
  endif()
endif()
foreach(tool ${CORDE_TOOL_TARGETS})
  if(catkin_FOUND)
    set_target_properties(${tool} PROPERTIES
      RUNTIME_OUTPUT_DIRECTORY ${CATKIN_DEVEL_PREFIX}/${CATKIN_PACKAGE_BIN_DESTINATION})
    add_custom_command(TARGET ${tool} POST_BUILD
      COMMAND ${CMAKE_COMMAND} -E create_symlink $<TARGET_FILE:${tool}> ${PROJECT_BINARY_DIR}/${tool}
      VERBATIM)
  else()
    set_target_properties(${tool} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR})
  endif()
endforeach()

