# corde_sim build module: catkin, messages, services, dynamic_reconfigure; must come before the targets so that
# catkin's output directories apply to them (included by the top-level CMakeLists.txt).

set(CORDE_ROS_COMPONENTS
  diagnostic_msgs diagnostic_updater dynamic_reconfigure geometry_msgs interactive_markers
  message_generation nav_msgs roscpp rosgraph_msgs roslib sensor_msgs shape_msgs std_msgs std_srvs
  tf2 tf2_msgs tf2_ros visualization_msgs)
if(CORDE_WITH_ROS)
  # catkin snapshots the devel environment at configure time (build/catkin_generated/
  # setup_cached.sh, used by every ctest/rostest command) and only lists folders that exist
  # then. On a first configure the generated Python messages (devel/lib/python3/dist-packages)
  # do not exist yet, PYTHONPATH would be cached empty and Python test nodes could not import
  # corde_sim.msg. Create the folders first.
  set(_corde_devel ${CMAKE_BINARY_DIR}/devel)
  if(CATKIN_DEVEL_PREFIX)
    set(_corde_devel ${CATKIN_DEVEL_PREFIX})
  endif()
  file(MAKE_DIRECTORY ${_corde_devel}/lib/python3/dist-packages ${_corde_devel}/lib/pkgconfig)
  # Optional on purpose: without ROS the rod library, tools and unit tests still build.
  #catkin_lint: ignore_once missing_required
  find_package(catkin QUIET COMPONENTS ${CORDE_ROS_COMPONENTS})
endif()

# Globs use CONFIGURE_DEPENDS so that a file added later is picked up by a plain rebuild (also
# the glob over src/tools, which only serves that purpose for the if(EXISTS) tests).
file(GLOB CORDE_MSG_FILES CONFIGURE_DEPENDS RELATIVE ${PROJECT_SOURCE_DIR}/msg
  ${PROJECT_SOURCE_DIR}/msg/*.msg)
file(GLOB CORDE_SRV_FILES CONFIGURE_DEPENDS RELATIVE ${PROJECT_SOURCE_DIR}/srv
  ${PROJECT_SOURCE_DIR}/srv/*.srv)
file(GLOB CORDE_CFG_FILES CONFIGURE_DEPENDS RELATIVE ${PROJECT_SOURCE_DIR}
  ${PROJECT_SOURCE_DIR}/cfg/*.cfg)
file(GLOB CORDE_ROS_SOURCES CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/src/ros/*.cpp)
file(GLOB CORDE_NODE_SOURCES CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/src/nodes/*.cpp)
file(GLOB CORDE_ROSTEST_FILES CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/test/ros/*.test)
file(GLOB CORDE_ROSTEST_SOURCES CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/test/ros/*.cpp)
file(GLOB CORDE_TOOL_SOURCES CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/src/tools/*.cpp)

if(catkin_FOUND)
  message(STATUS "${PROJECT_NAME}: catkin found, building the ROS adapter")
  # The Python package corde_sim (python/corde_sim, setup.py; CordePython.cmake builds its
  # extension): relayed into the devel space and installed with the generated messages, which
  # share its name. catkin wants this before generate_messages().
  catkin_python_setup()
  if(CORDE_MSG_FILES)
    add_message_files(DIRECTORY msg FILES ${CORDE_MSG_FILES})
  endif()
  if(CORDE_SRV_FILES)
    add_service_files(DIRECTORY srv FILES ${CORDE_SRV_FILES})
  endif()
  set(CORDE_HAS_MESSAGES OFF)
  if(CORDE_MSG_FILES OR CORDE_SRV_FILES)
    generate_messages(DEPENDENCIES geometry_msgs shape_msgs std_msgs)
    set(CORDE_HAS_MESSAGES ON)
  endif()
  # dynamic_reconfigure: cfg/Node.cfg generates corde_sim/NodeConfig.h (devel/include) and the
  # Python module corde_sim.cfg.NodeConfig; target ${PROJECT_NAME}_gencfg runs the generator.
  # Needs python3-dynamic-reconfigure (the generator's Python half).
  set(CORDE_HAS_CFG OFF)
  if(CORDE_CFG_FILES)
    generate_dynamic_reconfigure_options(${CORDE_CFG_FILES})
    set(CORDE_HAS_CFG ON)
  endif()

  set(CORDE_CATKIN_LIBRARIES corde_core)
  if(CORDE_ROS_SOURCES)
    list(APPEND CORDE_CATKIN_LIBRARIES corde_ros)
  endif()
  catkin_package(
    INCLUDE_DIRS include
    LIBRARIES ${CORDE_CATKIN_LIBRARIES}
    CATKIN_DEPENDS diagnostic_msgs diagnostic_updater dynamic_reconfigure geometry_msgs
                   interactive_markers message_runtime nav_msgs roscpp rosgraph_msgs roslib
                   sensor_msgs shape_msgs std_msgs std_srvs tf2 tf2_msgs tf2_ros
                   visualization_msgs
  )

  # catkin and roscpp's CMake modules add directory-wide include folders and definitions
  # (devel/include, ROS_PACKAGE_NAME, ROSCONSOLE_BACKEND_LOG4CXX, ROS_BUILD_SHARED_LIBS). Keep
  # them for the ROS targets only: the library, its tools and unit tests must not see them.
  get_directory_property(CORDE_ROS_DIR_INCLUDES INCLUDE_DIRECTORIES)
  get_directory_property(CORDE_ROS_DIR_DEFINITIONS COMPILE_DEFINITIONS)
  set_directory_properties(PROPERTIES INCLUDE_DIRECTORIES "" COMPILE_DEFINITIONS "")
else()
  message(STATUS "${PROJECT_NAME}: catkin not found, building the rod library, tools and unit tests only")
endif()

# Testing: catkin's CATKIN_ENABLE_TESTING (default ON) decides, as for any catkin package; when
# it is off, no test is configured. A build without ROS has the same option.
if(NOT catkin_FOUND)
  #catkin_lint: ignore_once global_var_collision
  option(CATKIN_ENABLE_TESTING "Configure the tests (catkin's option, also used without ROS)" ON)
endif()
