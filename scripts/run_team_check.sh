#!/usr/bin/env bash
# The team check (the demo before the scenarios; now a test, test/CMakeLists: team_check):
# launch/demo.launch on a private ROS master, then team_check, which validates every vehicle
# and its TF frames. Exits with team_check's status.
# Environment: AVSP_GUI=1 also starts RViz; AVSP_DEMO_TIMEOUT (s, default 30).
set -euo pipefail
export PATH="/usr/bin:/bin:${PATH}"
# The private master's port: free, below the ephemeral range (scripts/free_port.py).
port="$(/usr/bin/python3 "$(dirname "${BASH_SOURCE[0]}")/free_port.py")" || exit 1
export ROS_MASTER_URI="http://127.0.0.1:${port}"
export ROS_IP=127.0.0.1
gui=false; [ "${AVSP_GUI:-0}" = 1 ] && gui=true
timeout_s="${AVSP_DEMO_TIMEOUT:-30}"
share="$(rospack find avsp)" || { echo "run_team_check: rospack cannot find package avsp (source install/setup.sh)" >&2; exit 1; }

# By path: with both the source tree and install/ on ROS_PACKAGE_PATH the name is ambiguous.
roslaunch -p "$port" "$share/launch/demo.launch" gui:=$gui &
launch_pid=$!
cleanup() { kill -INT "$launch_pid" 2>/dev/null || true; wait "$launch_pid" 2>/dev/null || true; }
trap cleanup EXIT

# team_check needs the master: wait for it (bounded), then let team_check wait for TF.
master_up=0
for _ in $(seq 1 100); do
  rostopic list >/dev/null 2>&1 && { master_up=1; break; }
  kill -0 "$launch_pid" 2>/dev/null || { echo "run_team_check: roslaunch exited early" >&2; exit 1; }
  sleep 0.1
done
[ $master_up = 1 ] || { echo "run_team_check: no ROS master on port $port after 10 s" >&2; exit 1; }
rosparam load "$share/config/reference_team.yaml" /team_check
rc=0
# The executable through roslib (rosrun stops at same-named build folders under the source tree).
exe="$(/usr/bin/python3 -c "import roslib.packages as p; print((p.find_node('avsp', 'team_check') or [''])[0])")"
[ -n "$exe" ] || { echo "run_team_check: team_check is not built" >&2; exit 1; }
"$exe" __name:=team_check _config_dir:="$share/config/vehicles" _timeout:="$timeout_s" || rc=$?
if [ "$gui" = true ] && [ $rc -eq 0 ]; then
  echo "run_team_check: RViz is running; close it or press Ctrl-C to stop."
  wait "$launch_pid" || true
fi
exit $rc
