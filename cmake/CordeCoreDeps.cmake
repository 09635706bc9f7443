# corde_sim build module: dependencies of the rod library (no ROS) (included by the top-level CMakeLists.txt).

find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(yaml-cpp REQUIRED)
find_package(Threads REQUIRED)
# Obstacles (src/core/contact/obstacle.cpp, urdf_obstacles.cpp): FCL 0.7 for the distance queries,
# urdfdom for robot descriptions, assimp for their mesh files; tinyxml2 reads the URDF's text
# as well (src/core/contact/urdf_checks.cpp: what urdfdom drops without a word, bounded nesting).
find_package(fcl REQUIRED)
find_package(urdfdom REQUIRED)
find_package(tinyxml2 REQUIRED)
find_package(assimp REQUIRED)
if(TARGET assimp::assimp)
  set(CORDE_ASSIMP_TARGET assimp::assimp)
else()
  set(CORDE_ASSIMP_TARGET ${ASSIMP_LIBRARIES})
endif()
if(TARGET yaml-cpp)
  set(CORDE_YAML_TARGET yaml-cpp)
elseif(TARGET yaml-cpp::yaml-cpp)
  set(CORDE_YAML_TARGET yaml-cpp::yaml-cpp)
else()
  message(FATAL_ERROR "yaml-cpp found but it exports no yaml-cpp target")
endif()

