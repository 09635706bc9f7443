# corde_sim build module: the Python package (python/corde_sim) and its extension module _core
# (src/python, pybind11 from Debian), docs/python.md (included by the top-level CMakeLists.txt
# after the library).
#
# Where the package is importable from:
# - with catkin: the devel space. catkin_python_setup (CordeCatkin.cmake) relays
#   devel/lib/python3/dist-packages/<package> to python/<package>, _core is built next to the
#   relay and the generated messages, so `source build/devel/setup.bash` is all it takes; an
#   install puts everything in lib/python3/dist-packages/<package>.
# - without catkin: build/python (the sources linked there, _core beside them); `make install`
#   puts it in lib/python3/dist-packages.
# CORDE_PYTHON_PATH is that folder, for the tests' PYTHONPATH.

#catkin_lint: ignore_once global_var_collision
option(CORDE_PYTHON "Build the Python module (needs pybind11-dev)" ON)
set(CORDE_PYTHON_PATH "")
if(NOT CORDE_PYTHON)
  return()
endif()
find_package(pybind11 CONFIG QUIET)
if(NOT pybind11_FOUND)
  message(WARNING "${PROJECT_NAME}: pybind11 not found (apt-get install pybind11-dev), the "
                  "Python module is not built")
  return()
endif()

# A plain module library rather than pybind11_add_module: no link-time optimisation (its
# lto-wrapper warnings would break a clean build), and a target catkin_lint can follow.
file(GLOB CORDE_PYTHON_SOURCES CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/src/python/*.cpp)
set(CORDE_PYTHON_TARGET ${PROJECT_NAME}_python)
add_library(${PROJECT_NAME}_python MODULE ${CORDE_PYTHON_SOURCES})
target_link_libraries(${PROJECT_NAME}_python PRIVATE corde_core pybind11::module)
set_target_properties(${PROJECT_NAME}_python PROPERTIES
  OUTPUT_NAME _core
  PREFIX "${PYTHON_MODULE_PREFIX}"
  SUFFIX "${PYTHON_MODULE_EXTENSION}"
  CXX_VISIBILITY_PRESET hidden
  VISIBILITY_INLINES_HIDDEN ON)

if(catkin_FOUND)
  set(CORDE_PYTHON_PATH ${CATKIN_DEVEL_PREFIX}/${CATKIN_GLOBAL_PYTHON_DESTINATION})
  set_target_properties(${PROJECT_NAME}_python PROPERTIES
    LIBRARY_OUTPUT_DIRECTORY ${CATKIN_DEVEL_PREFIX}/${CATKIN_PACKAGE_PYTHON_DESTINATION})
  install(TARGETS ${PROJECT_NAME}_python
    LIBRARY DESTINATION ${CATKIN_PACKAGE_PYTHON_DESTINATION})
  # corde_batch: `rosrun <package> corde_batch` in the devel space and once installed.
  catkin_install_python(PROGRAMS scripts/corde_batch DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
else()
  set(CORDE_PYTHON_PATH ${PROJECT_BINARY_DIR}/python)
  set(_py_dir ${CORDE_PYTHON_PATH}/${PROJECT_NAME})
  file(MAKE_DIRECTORY ${_py_dir})
  file(GLOB _py_files CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/python/${PROJECT_NAME}/*.py)
  foreach(_f ${_py_files})
    get_filename_component(_name ${_f} NAME)
    file(CREATE_LINK ${_f} ${_py_dir}/${_name} SYMBOLIC)
  endforeach()
  set_target_properties(${PROJECT_NAME}_python PROPERTIES LIBRARY_OUTPUT_DIRECTORY ${_py_dir})
  install(TARGETS ${PROJECT_NAME}_python
    LIBRARY DESTINATION lib/python3/dist-packages/${PROJECT_NAME})
  install(FILES ${_py_files} DESTINATION lib/python3/dist-packages/${PROJECT_NAME})
  install(PROGRAMS scripts/corde_batch DESTINATION bin)
endif()
# The build folder links the command next to corde_run (./build/corde_batch); it needs the
# package on PYTHONPATH (source build/devel/setup.bash).
file(CREATE_LINK ${PROJECT_SOURCE_DIR}/scripts/corde_batch ${PROJECT_BINARY_DIR}/corde_batch
  SYMBOLIC)
