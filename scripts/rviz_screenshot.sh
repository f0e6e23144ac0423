#!/usr/bin/env bash
# Starts the reference team's descriptions and RViz with rviz/avsp.rviz under Xvfb with
# software GL, waits for RViz to draw, and saves a screenshot of the virtual screen.
# Not a CI test: a way for anyone to see what a user sees. Run from a built tree:
#   make screenshot           (writes results/rviz_team.png)
#   bash scripts/rviz_screenshot.sh OUT.png [SECONDS_TO_WAIT, default 25]
set -euo pipefail
export PATH="/usr/bin:/bin:${PATH}"
out="${1:?usage: rviz_screenshot.sh OUT.png [SECONDS]}"
wait_s="${2:-25}"
for tool in Xvfb import rviz roslaunch; do
  command -v "$tool" >/dev/null || { echo "rviz_screenshot: '$tool' not found (make screenshot installs it)" >&2; exit 1; }
done
mkdir -p "$(dirname "$out")"
share="$(rospack find avsp)" || { echo "rviz_screenshot: rospack cannot find package avsp (source install/setup.sh)" >&2; exit 1; }
display_num=$(( 90 + RANDOM % 9 ))
# The private master's port: free, below the ephemeral range (scripts/free_port.py).
port="$(/usr/bin/python3 "$(dirname "${BASH_SOURCE[0]}")/free_port.py")" || exit 1
export DISPLAY=":${display_num}" ROS_MASTER_URI="http://127.0.0.1:${port}" ROS_IP=127.0.0.1
export LIBGL_ALWAYS_SOFTWARE=1

Xvfb "$DISPLAY" -screen 0 1320x960x24 -nolisten tcp &
xvfb_pid=$!
launch_pid=""
cleanup() {
  [ -n "$launch_pid" ] && { kill -INT "$launch_pid" 2>/dev/null || true; wait "$launch_pid" 2>/dev/null || true; }
  kill "$xvfb_pid" 2>/dev/null || true
}
trap cleanup EXIT
sleep 1
kill -0 "$xvfb_pid" 2>/dev/null || { echo "rviz_screenshot: Xvfb did not start on $DISPLAY" >&2; exit 1; }

roslaunch -p "$port" "$share/launch/demo.launch" gui:=true &
launch_pid=$!
# RViz under software GL needs a while to load meshes and draw; there is no 'drawn' event
# to wait for, and this script is a viewing aid, not a test.
sleep "$wait_s"
kill -0 "$launch_pid" 2>/dev/null || { echo "rviz_screenshot: roslaunch exited early" >&2; exit 1; }
import -window root "$out"
echo "rviz_screenshot: wrote $out"
