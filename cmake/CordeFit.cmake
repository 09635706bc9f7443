# corde_sim build module: corde_fit, the identification of a cable's material from recorded
# motion (python/corde_sim/fit.py, scripts/corde_fit, docs/calibration.md), and its tests
# (included by the top-level CMakeLists.txt after CordePython.cmake and CordeTests.cmake). It
# needs the Python module: without it (no pybind11), nothing here is built or tested.
if(NOT CORDE_PYTHON_PATH)
  return()
endif()
if(catkin_FOUND)
  # `rosrun corde_sim corde_fit` once installed
  catkin_install_python(PROGRAMS scripts/corde_fit DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
else()
  install(PROGRAMS scripts/corde_fit DESTINATION bin)
endif()
# ./build/corde_fit beside corde_run; it needs the package on PYTHONPATH
# (source build/devel/setup.bash).
file(CREATE_LINK ${PROJECT_SOURCE_DIR}/scripts/corde_fit ${PROJECT_BINARY_DIR}/corde_fit SYMBOLIC)

# Recovery of known parameters from synthetic recordings, model mismatch, the command on a rosbag
# and its messages (label python; the long coverage run: test/python/fit_test.py --long).
if(CATKIN_ENABLE_TESTING AND TARGET ${PROJECT_NAME}_python AND TARGET corde_run)
  foreach(_py fit_test fit_cli_test fit_jacobian_test)
    add_test(NAME python_${_py}
      COMMAND ${PYTHON_EXECUTABLE} ${PROJECT_SOURCE_DIR}/test/python/${_py}.py
      WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})
    set_tests_properties(python_${_py} PROPERTIES LABELS python TIMEOUT 600
      ENVIRONMENT "PYTHONPATH=${CORDE_PYTHON_PATH};CORDE_RUN=$<TARGET_FILE:corde_run>")
  endforeach()
endif()
