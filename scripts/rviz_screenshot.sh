#!/usr/bin/env bash
# Runs the reference traverse at wall-clock pace with RViz (the run's own configuration, written
# by scenario_launch: the view follows the lead vehicle) under Xvfb with software GL, waits
# until the run's sim time reaches SIM_SECONDS and RViz has had time to draw, and saves a
# screenshot of the virtual screen: what a user of `make demo-gui` sees at that time.
# Not a CI test: a way for anyone to see what a user sees. Run from a built tree:
#   make screenshot                       (writes results/rviz_reference_traverse.png)
#   bash scripts/rviz_screenshot.sh OUT.png [SIM_SECONDS, default 40] [WALL_LIMIT_S, default 900]
set -euo pipefail
export PATH="/usr/bin:/bin:${PATH}"
out="${1:?usage: rviz_screenshot.sh OUT.png [SIM_SECONDS] [WALL_LIMIT_S]}"
sim_s="${2:-40}"
limit_s="${3:-900}"
for tool in Xvfb import rviz roslaunch; do
  command -v "$tool" >/dev/null || { echo "rviz_screenshot: '$tool' not found (make screenshot installs it)" >&2; exit 1; }
done
mkdir -p "$(dirname "$out")"
out="$(cd "$(dirname "$out")" && pwd)/$(basename "$out")"
share="$(rospack find avsp)" || { echo "rviz_screenshot: rospack cannot find package avsp (source install/setup.sh)" >&2; exit 1; }
display_num=$(( 90 + RANDOM % 9 ))
# The private master's port: free, below the ephemeral range (scripts/free_port.py).
port="$(/usr/bin/python3 "$(dirname "${BASH_SOURCE[0]}")/free_port.py")" || exit 1
export DISPLAY=":${display_num}" ROS_MASTER_URI="http://127.0.0.1:${port}" ROS_IP=127.0.0.1
export LIBGL_ALWAYS_SOFTWARE=1
run_dir="$(mktemp -d /tmp/avsp_screenshot.XXXXXX)"

Xvfb "$DISPLAY" -screen 0 1320x960x24 -nolisten tcp &
xvfb_pid=$!
launch_pid=""
cleanup() {
  [ -n "$launch_pid" ] && { kill -INT "$launch_pid" 2>/dev/null || true; wait "$launch_pid" 2>/dev/null || true; }
  kill "$xvfb_pid" 2>/dev/null || true
  rm -rf "$run_dir"
}
trap cleanup EXIT
sleep 1
kill -0 "$xvfb_pid" 2>/dev/null || { echo "rviz_screenshot: Xvfb did not start on $DISPLAY" >&2; exit 1; }

roslaunch -p "$port" "$share/launch/reference_traverse.launch" rviz:=true real_time_factor:=1 \
  output_dir:="$run_dir/results" > "$run_dir/launch.log" 2>&1 &
launch_pid=$!
# Until the run's sim time reaches sim_s (the column under way), or the wall limit.
/usr/bin/python3 - "$sim_s" "$limit_s" <<'EOF' || { echo "rviz_screenshot: the run did not reach ${sim_s} s of sim time (log: see below)" >&2; tail -20 "$run_dir/launch.log" >&2; exit 1; }
import sys, time
import rospy
from rosgraph_msgs.msg import Clock
target, deadline = float(sys.argv[1]), time.time() + float(sys.argv[2])
while time.time() < deadline:
    try:
        rospy.init_node("rviz_screenshot_probe", anonymous=True, disable_signals=True)
        break
    except Exception:  # the master is not up yet
        time.sleep(1.0)
while time.time() < deadline:
    try:
        if rospy.wait_for_message("/clock", Clock, timeout=10).clock.to_sec() >= target:
            sys.exit(0)
    except rospy.ROSException:
        pass
sys.exit(1)
EOF
# RViz under software GL draws a frame in a few seconds; there is no 'drawn' event to wait for,
# and this script is a viewing aid, not a test.
sleep 5
kill -0 "$launch_pid" 2>/dev/null || { echo "rviz_screenshot: roslaunch exited early" >&2; tail -20 "$run_dir/launch.log" >&2; exit 1; }
import -window root "$out"
echo "rviz_screenshot: wrote $out (reference traverse at ${sim_s} s of sim time)"
