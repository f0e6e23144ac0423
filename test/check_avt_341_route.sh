#!/usr/bin/env bash
# avt_341_route_check.py, the AVT-341 stack's path node's launch-prefix: a route inside the
# grid runs the command, one leaving it (or malformed) stops with exit 1 naming the waypoint.
set -u
check="$(dirname "$0")/../scripts/avt_341_route_check.py"
failed=0
run() {  # run EXPECTED_RC EXPECTED_TEXT WAYPOINTS_X WAYPOINTS_Y
  local out rc
  out="$(/usr/bin/python3 "$check" --grid-llx -60 --grid-lly 110 --grid-size 200 --waypoints-x "$3" --waypoints-y "$4" -- /bin/echo started 2>&1)"
  rc=$?
  if [ "$rc" = "$1" ] && [[ "$out" == *"$2"* ]]; then echo "ok: $3 $4 -> $rc"
  else echo "FAILED: $3 $4: exit $rc, output '$out'; expected $1 and '$2'"; failed=1; fi
}
run 0 "started" "[130.0]" "[200.0]"
run 0 "started" "[-60, 139.9]" "[110, 309.9]"
run 1 "waypoint 1 (140, 200) lies outside the stack's grid x [-60, 140) y [110, 310) m" "[130.0, 140.0]" "[200.0, 200.0]"
run 1 "waypoint 0 (130, 100) lies outside" "[130.0]" "[100.0]"
run 1 "waypoints_x has 2 entries, waypoints_y 1" "[1, 2]" "[200]"
run 1 "waypoints_y must be a non-empty YAML list of finite numbers" "[100]" "[.nan]"
run 1 "waypoints_x must be a non-empty YAML list" "130" "[200]"
exit $failed
