#!/usr/bin/env bash
# Installs the Debian 12 (bookworm) packages corde_sim needs: compiler and CMake, the rod
# library's dependencies, Debian's own ROS 1 packages (under /usr, no /opt/ros), test and
# benchmark frameworks, and Xvfb + Mesa + ImageMagick for headless rviz screenshots.
#
# Fast no-op when everything is installed: apt-get (update + install) runs only when dpkg reports
# a package missing. Uses sudo when not run as root. Also makes sure `localhost` and the host name
# resolve (ROS needs both; a minimal system may lack /etc/hosts).
#
#   scripts/install_deps.sh          # build, test and run dependencies
#   scripts/install_deps.sh --list   # print the package list and exit
set -euo pipefail

packages=(
  # toolchain
  g++ make cmake pkg-config
  # rod library (obstacles: FCL, urdfdom, assimp; tinyxml2 checks URDF text)
  libeigen3-dev libyaml-cpp-dev libfcl-dev liburdfdom-dev libassimp-dev libtinyxml2-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  # the formatting check (ctest format_check)
  clang-format
  # the scene reader's fuzz test (libFuzzer comes with libclang-rt-dev, only recommended by clang)
  clang libclang-rt-dev
  # ROS 1 (Debian packages): build system, message generation, C++ client libraries
  ros-base-dev catkin python3-catkin-pkg ros-message-generation ros-message-runtime
  python3-genmsg python3-gencpp python3-genpy
  libroscpp-dev libroslib-dev libtf2-dev libtf2-ros-dev
  libstd-msgs-dev libstd-srvs-dev libgeometry-msgs-dev libnav-msgs-dev libtf2-msgs-dev
  libros-rosgraph-msgs-dev libdiagnostic-msgs-dev
  libvisualization-msgs-dev libdiagnostic-updater-dev libinteractive-markers-dev
  libsensor-msgs-dev libshape-msgs-dev
  # dynamic_reconfigure (cfg/Node.cfg): C++ headers, CMake macros and templates; the generator's
  # Python half (without it the NodeConfig.h generation fails)
  libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure
  # ROS 1 runtime: master, launch, rosout, rostest (python) and rostest's CMake macros
  python3-rosmaster python3-roslaunch python3-rosgraph python3-rospy python3-rosunit
  python3-rostest librostest-dev rosout rosbash python3-rostopic python3-rosservice
  # recording rod_state and the reactions (launch/corde_sim.launch record:=true: rosbag record)
  python3-rosbag
  # robot example (launch/robot_example.launch): robot description, joint and link tf
  ros-robot-state-publisher joint-state-publisher liburdf-dev
  # python nodes and rostests (scripts/demo_arm_motion.py, test/ros/*_test.py) and command-line
  # checks of the node (rostopic echo, rosservice call, tf_echo)
  python3-numpy python3-std-msgs python3-geometry-msgs python3-nav-msgs python3-sensor-msgs
  python3-tf2-msgs python3-rosgraph-msgs python3-std-srvs python3-diagnostic-msgs
  python3-visualization-msgs python3-tf2-ros tf-tools python3-shape-msgs
  # building in a catkin workspace (catkin build) and checking the package (catkin_lint)
  catkin-tools catkin-lint
  # visualisation: rviz, headless X server with software OpenGL, screenshots, charts
  rviz librviz-dev xvfb xauth libgl1-mesa-dri x11-utils imagemagick python3-matplotlib
  # validation references (scripts/timoshenko_frequencies.py)
  python3-scipy
  # the Python module corde_sim (pybind11) and corde_batch (Dask, HDF5, sweep files):
  # docs/python.md
  pybind11-dev python3-dev python3-setuptools python3-yaml python3-distributed python3-h5py
  # corde_fit (docs/calibration.md) uses python3-scipy and python3-rosbag, listed above
)

for arg in "$@"; do
  case "$arg" in
    --list) printf '%s\n' "${packages[@]}"; exit 0 ;;
    -h|--help) sed -n '2,12p' "$0"; exit 0 ;;
    *) echo "install_deps.sh: unknown option '$arg'" >&2; exit 2 ;;
  esac
done

sudo=()
if [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null 2>&1; then
  sudo=(sudo)
fi

# ROS needs `localhost` and this machine's host name to resolve: roslaunch/rostest always treat
# the local machine as `localhost`, and nodes advertise http://<hostname>:<port>/ URIs. A minimal
# system (debootstrap chroot, some containers) may have no /etc/hosts at all; add what is missing.
ensure_hosts() {
  local name names=(localhost)
  local host
  host=$(hostname 2>/dev/null || cat /etc/hostname 2>/dev/null || true)
  [ -n "$host" ] && names+=("$host")
  for name in "${names[@]}"; do
    if ! getent hosts "$name" >/dev/null 2>&1; then
      echo "install_deps.sh: '$name' does not resolve; adding '127.0.0.1 $name' to /etc/hosts"
      if [ "$(id -u)" -eq 0 ]; then
        echo "127.0.0.1 $name" >>/etc/hosts
      elif [ "${#sudo[@]}" -gt 0 ]; then
        echo "127.0.0.1 $name" | "${sudo[@]}" tee -a /etc/hosts >/dev/null
      else
        echo "install_deps.sh: cannot write /etc/hosts (not root, no sudo); ROS tests will fail" >&2
      fi
    fi
  done
}
ensure_hosts

# Which packages are not fully installed? (one dpkg-query call; unknown names are missing too)
mapfile -t installed < <(dpkg-query -W -f='${Package} ${db:Status-Status}\n' "${packages[@]}" \
  2>/dev/null | awk '$2 == "installed" {print $1}' | sort -u)
missing=()
for p in "${packages[@]}"; do
  found=0
  for q in "${installed[@]}"; do
    if [ "$p" = "$q" ]; then found=1; break; fi
  done
  [ "$found" = 1 ] || missing+=("$p")
done

if [ "${#missing[@]}" -eq 0 ]; then
  echo "install_deps.sh: all ${#packages[@]} packages are installed"
  exit 0
fi

echo "install_deps.sh: installing ${#missing[@]} missing packages: ${missing[*]}"
if [ "$(id -u)" -ne 0 ] && [ "${#sudo[@]}" -eq 0 ]; then
  echo "install_deps.sh: not root and sudo is not available; install as root:" >&2
  echo "  apt-get install ${missing[*]}" >&2
  exit 1
fi
"${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -q
"${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
  "${missing[@]}"
echo "install_deps.sh: done"
