# corde_sim build module: the ROS adapter library, the nodes, installation (included by the top-level CMakeLists.txt).

if(catkin_FOUND)
  set(CORDE_ROS_DEPS ${catkin_EXPORTED_TARGETS})
  if(CORDE_HAS_MESSAGES)
    list(APPEND CORDE_ROS_DEPS ${PROJECT_NAME}_generate_messages_cpp)
  endif()
  if(CORDE_HAS_CFG)
    list(APPEND CORDE_ROS_DEPS ${PROJECT_NAME}_gencfg)
  endif()
  # Include folders and definitions every ROS target gets: the directory-wide ones of catkin
  # (generated message and NodeConfig headers in devel/include, ...) and the ROS packages'.
  macro(corde_ros_target target)
    target_include_directories(${target} PRIVATE ${CORDE_ROS_DIR_INCLUDES})
    target_include_directories(${target} SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
    target_compile_definitions(${target} PRIVATE ${CORDE_ROS_DIR_DEFINITIONS})
    target_link_libraries(${target} PRIVATE corde_core ${catkin_LIBRARIES})
    if(CORDE_ROS_DEPS)
      add_dependencies(${target} ${CORDE_ROS_DEPS})
    endif()
  endmacro()

  if(CORDE_ROS_SOURCES)
    add_library(corde_ros STATIC ${CORDE_ROS_SOURCES})
    corde_ros_target(corde_ros)
    target_link_libraries(corde_ros PUBLIC corde_core ${catkin_LIBRARIES})
    set_target_properties(corde_ros PROPERTIES POSITION_INDEPENDENT_CODE ON)
  endif()

  # Nodes: each src/nodes/<name>.cpp becomes the executable <name> (corde_sim_node, the
  # interactive grasp marker of launch/demo_thread.launch, ...), linked with corde_ros. They land
  # in devel/lib/corde_sim, where rosrun/roslaunch look for them.
  set(CORDE_NODE_TARGETS)
  foreach(src ${CORDE_NODE_SOURCES})
    get_filename_component(name ${src} NAME_WE)
    add_executable(${name} ${src})
    if(TARGET corde_ros)
      target_link_libraries(${name} PRIVATE corde_ros)
    endif()
    corde_ros_target(${name})
    list(APPEND CORDE_NODE_TARGETS ${name})
  endforeach()

  install(TARGETS ${CORDE_CATKIN_LIBRARIES}
    ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
    LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
    RUNTIME DESTINATION ${CATKIN_GLOBAL_BIN_DESTINATION})
  set(CORDE_BIN_TARGETS ${CORDE_NODE_TARGETS} ${CORDE_TOOL_TARGETS})
  if(CORDE_BIN_TARGETS)
    list(SORT CORDE_BIN_TARGETS)
    install(TARGETS ${CORDE_BIN_TARGETS} RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
  endif()
  # Python nodes started by launch files (scripts/ also holds developer tools that run from the
  # source tree: install_deps.sh, screenshot.sh, plots; they are not installed).
  #catkin_lint: ignore uninstalled_script
  foreach(script scripts/demo_arm_motion.py)
    if(EXISTS "${PROJECT_SOURCE_DIR}/${script}")
      catkin_install_python(PROGRAMS ${script} DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
    endif()
  endforeach()
  install(DIRECTORY include/${PROJECT_NAME}/ DESTINATION ${CATKIN_PACKAGE_INCLUDE_DESTINATION})
  # launch files, rviz configurations and scenes (config/scenes), robot descriptions
  foreach(dir config launch urdf)
    if(IS_DIRECTORY "${PROJECT_SOURCE_DIR}/${dir}")
      install(DIRECTORY ${dir} DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION})
    endif()
  endforeach()
endif()
