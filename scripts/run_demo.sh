#!/usr/bin/env bash
# The main job (`make demo`): the reference traverse headless, as fast as possible in lockstep
# (launch/reference_traverse.launch, real_time_factor 0) on a private ROS master. run_recorder
# prints a progress line per second and writes results/reference_traverse/ (summary.json,
# trajectories.png, ruts.png, gaps.png); the run ends at the scenario's duration. Exits 0 only
# if every result file was written by this run and the run was not aborted (summary.json).
# Environment: AVSP_GUI=1 also starts RViz (and paces the run at wall-clock speed);
# AVSP_DEMO_DURATION (s of sim time, default the scenario's 600); AVSP_DEMO_TIMEOUT (wall s,
# default 3600); AVSP_SCENARIO (default config/scenarios/reference_traverse.yaml).
set -euo pipefail
export PATH="/usr/bin:/bin:${PATH}"
share="$(rospack find avsp)" || { echo "run_demo: rospack cannot find package avsp (source install/setup.sh)" >&2; exit 1; }
scenario="${AVSP_SCENARIO:-$share/config/scenarios/reference_traverse.yaml}"
name="$(basename "${scenario%.*}")"
out="$PWD/results/$name"
# The private master's port: free, below the ephemeral range (scripts/free_port.py).
port="$(/usr/bin/python3 "$(dirname "${BASH_SOURCE[0]}")/free_port.py")" || exit 1
export ROS_MASTER_URI="http://127.0.0.1:${port}"
export ROS_IP=127.0.0.1
gui=false; rtf=0
[ "${AVSP_GUI:-0}" = 1 ] && { gui=true; rtf=1; }

# Without run_recorder the run would never end.
/usr/bin/python3 -c "import roslib.packages as p, sys; sys.exit(0 if p.find_node('avsp', 'run_recorder') else 1)" \
  || { echo "run_demo: run_recorder is not built: the reference traverse cannot write its results" >&2; exit 1; }
mkdir -p "$out"
stamp="$out/.run_started"
touch "$stamp"
rc=0
timeout --signal=INT --kill-after=30 "${AVSP_DEMO_TIMEOUT:-3600}" \
  roslaunch -p "$port" "$share/launch/reference_traverse.launch" scenario:="$scenario" output_dir:="$out" \
    real_time_factor:=$rtf rviz:=$gui duration:="${AVSP_DEMO_DURATION:-0}" || rc=$?
[ $rc -eq 124 ] && { echo "run_demo: the run did not end within ${AVSP_DEMO_TIMEOUT:-3600} s (wall)" >&2; exit 1; }
missing=0
for f in summary.json trajectories.png ruts.png gaps.png; do
  if [ ! -s "$out/$f" ] || [ ! "$out/$f" -nt "$stamp" ]; then
    echo "run_demo: $out/$f was not written by this run" >&2; missing=1
  fi
done
rm -f "$stamp"
[ $missing = 0 ] || exit 1
# roslaunch exits 0 whatever its nodes did: run_recorder's summary says whether the run failed.
aborted="$(/usr/bin/python3 -c 'import json, sys; a = json.load(open(sys.argv[1])).get("aborted"); print("" if a is None else "%s at sim time %s s: %s" % (a["node"], a["sim_time"], a["reason"]))' "$out/summary.json")" \
  || { echo "run_demo: $out/summary.json cannot be read" >&2; exit 1; }
[ -z "$aborted" ] || { echo "run_demo: the run was aborted: $aborted (results so far in $out)" >&2; exit 1; }
echo "run_demo: results in $out (roslaunch exit $rc)"
