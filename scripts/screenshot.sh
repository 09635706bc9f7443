#!/usr/bin/env bash
# Renders a corde_sim demo in rviz under a virtual X server (Xvfb, Mesa software OpenGL) and saves
# a screenshot of the whole screen (ImageMagick's `import`).
#
#   scripts/screenshot.sh [LAUNCH] [SECONDS] [OUTPUT] [launch args...]
#     LAUNCH   launch file of the corde_sim package (default corde_sim.launch)
#     SECONDS  how long the simulation runs before the shot (default 6)
#     OUTPUT   PNG to write (default docs/rviz_demo.png)
#
# Needs a built workspace: sources $CORDE_DEVEL/setup.bash, else build/devel/setup.bash. Uses its
# own ROS master on port 11411 (ROS_MASTER_URI is overridden) so that it does not disturb a
# running one. Packages: xvfb, imagemagick, rviz, libgl1-mesa-dri (scripts/install_deps.sh).
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
launch="${1:-corde_sim.launch}"
seconds="${2:-6}"
output="${3:-$root/docs/rviz_demo.png}"
shift $(( $# < 3 ? $# : 3 ))

devel="${CORDE_DEVEL:-$root/build/devel}"
if [ ! -f "$devel/setup.bash" ]; then
  echo "screenshot.sh: no $devel/setup.bash; build first (make build) or set CORDE_DEVEL" >&2
  exit 1
fi
for tool in Xvfb import rviz roslaunch; do
  command -v "$tool" > /dev/null || { echo "screenshot.sh: $tool not found (scripts/install_deps.sh)" >&2; exit 1; }
done
set +u
# shellcheck disable=SC1091
source "$devel/setup.bash"
set -u

# A free display number.
display=99
while [ -e "/tmp/.X11-unix/X$display" ] || [ -e "/tmp/.X$display-lock" ]; do display=$((display + 1)); done
export DISPLAY=":$display"
export LIBGL_ALWAYS_SOFTWARE=1
export ROS_MASTER_URI="http://localhost:11411"
export ROS_LOG_DIR="${ROS_LOG_DIR:-$(mktemp -d)}"

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

roslaunch -p 11411 corde_sim "$launch" "$@" > "$ROS_LOG_DIR/roslaunch.log" 2>&1 &
pids=($! "${pids[@]}")

# rviz needs a few seconds to start under software rendering before the clock matters.
sleep "$seconds"
mkdir -p "$(dirname "$output")"
import -display "$DISPLAY" -window root "$output"
echo "screenshot.sh: wrote $output ($(identify -format '%wx%h' "$output")); logs in $ROS_LOG_DIR"
