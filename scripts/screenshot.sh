#!/usr/bin/env bash
# Renders a corde_sim demo in rviz under a virtual X server (Xvfb, Mesa software OpenGL) and saves
# a screenshot of the whole screen (ImageMagick's `import`).
#
#   scripts/screenshot.sh [LAUNCH] [SECONDS] [OUTPUT] [launch args...]
#     LAUNCH   launch file of the corde_sim package (default corde_sim.launch)
#     SECONDS  how long the simulation runs after rviz has drawn its first picture (default 6)
#     OUTPUT   PNG to write (default docs/rviz_demo.png)
#
# Environment:
#   CORDE_DEVEL        devel space to source; default: the first catkin devel space on
#                      CMAKE_PREFIX_PATH that holds corde_sim_node, else build/devel
#   CORDE_MASTER_PORT  port of the script's own ROS master; default: the first free port from
#                      11411 (never the master of ROS_MASTER_URI, so a running system is left alone)
#   CORDE_DRAW_TIMEOUT seconds to wait for rviz's first picture (default 120)
#
# Software rendering on a slow machine takes a while before rviz draws anything: the script polls
# screenshots until the middle of the 3D view shows a picture (more than a few colours), then lets
# the simulation run SECONDS more. Packages: xvfb, imagemagick, rviz, libgl1-mesa-dri
# (scripts/install_deps.sh).
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
launch="${1:-corde_sim.launch}"
seconds="${2:-6}"
output="${3:-$root/docs/rviz_demo.png}"
shift $(( $# < 3 ? $# : 3 ))
draw_timeout="${CORDE_DRAW_TIMEOUT:-120}"

die() { echo "screenshot.sh: $*" >&2; exit 1; }

# The devel space: given, or the current one if it has the node, or the repository's build.
devel="${CORDE_DEVEL:-}"
if [ -z "$devel" ]; then
  IFS=: read -r -a prefixes <<< "${CMAKE_PREFIX_PATH:-}"
  for p in "${prefixes[@]}"; do
    if [ -f "$p/setup.bash" ] && [ -x "$p/lib/corde_sim/corde_sim_node" ]; then devel="$p"; break; fi
  done
fi
devel="${devel:-$root/build/devel}"
[ -f "$devel/setup.bash" ] || die "no $devel/setup.bash; build first (make build) or set CORDE_DEVEL"
for tool in Xvfb import identify convert rviz roslaunch; do
  command -v "$tool" > /dev/null || die "$tool not found (scripts/install_deps.sh)"
done
set +u
# shellcheck disable=SC1091
source "$devel/setup.bash"
set -u

port_free() { ! (exec 3<> "/dev/tcp/127.0.0.1/$1") 2> /dev/null; }
port="${CORDE_MASTER_PORT:-}"
if [ -z "$port" ]; then
  port=11411
  while ! port_free "$port"; do port=$((port + 1)); done
fi
port_free "$port" || die "port $port is in use (CORDE_MASTER_PORT)"

# A free display number.
display=99
while [ -e "/tmp/.X11-unix/X$display" ] || [ -e "/tmp/.X$display-lock" ]; do display=$((display + 1)); done
export DISPLAY=":$display"
export LIBGL_ALWAYS_SOFTWARE=1
export ROS_MASTER_URI="http://localhost:$port"
export ROS_LOG_DIR="${ROS_LOG_DIR:-$(mktemp -d)}"
mkdir -p "$ROS_LOG_DIR"

pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill -INT "$pid" 2> /dev/null || true; done
  sleep 2
  for pid in "${pids[@]}"; do kill -KILL "$pid" 2> /dev/null || true; done
}
trap cleanup EXIT

Xvfb "$DISPLAY" -screen 0 1280x720x24 -nolisten tcp > "$ROS_LOG_DIR/xvfb.log" 2>&1 &
pids+=($!)
sleep 1
kill -0 "${pids[0]}" 2> /dev/null || die "Xvfb did not start; see $ROS_LOG_DIR/xvfb.log"

roslaunch -p "$port" corde_sim "$launch" "$@" > "$ROS_LOG_DIR/roslaunch.log" 2>&1 &
pids=($! "${pids[@]}")

# Wait for a picture: a 3D view not yet drawn is black or one flat colour. The probe is a
# 400 x 300 crop right of the middle, inside rviz's 3D view with the usual left panel.
probe="$ROS_LOG_DIR/probe.png"
start=$SECONDS
while :; do
  sleep 1
  kill -0 "${pids[0]}" 2> /dev/null || die "roslaunch exited; see $ROS_LOG_DIR/roslaunch.log"
  if import -display "$DISPLAY" -window root "$probe" 2> /dev/null; then
    colours=$(convert "$probe" -crop 400x300+640+200 +repage -format '%k' info:)
    echo "$((SECONDS - start)) s: $colours colours" >> "$ROS_LOG_DIR/probe.log"
    [ "$colours" -gt 20 ] && break
  fi
  [ $((SECONDS - start)) -lt "$draw_timeout" ] || die "rviz drew nothing in ${draw_timeout} s"
done
echo "screenshot.sh: rviz drew after $((SECONDS - start)) s; shot in $seconds s"

sleep "$seconds"
mkdir -p "$(dirname "$output")"
import -display "$DISPLAY" -window root "$output"
echo "screenshot.sh: wrote $output ($(identify -format '%wx%h' "$output")); logs in $ROS_LOG_DIR"
