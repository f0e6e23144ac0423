#!/usr/bin/env bash
# scripts/prefix_urdf.py, which vehicle_description.launch (and so avt_341.launch model:=<m>)
# runs for robot_description: a known model comes out with every link and joint end prefixed by
# the vehicle; an unknown model is one line naming it and the known ones, exit 1; a bad vehicle
# name exit 2.
# usage: check_prefix_urdf.sh
set -u
root="$(cd "$(dirname "$0")/.." && pwd)"
script="$root/scripts/prefix_urdf.py"
failed=0
out="$(python3 "$script" "$root/urdf/mrzr.urdf" ego)" || { echo "FAILED: mrzr exited $?"; failed=1; }
links="$(grep -o '<link name="[^"]*"' <<<"$out" | wc -l)"
prefixed="$(grep -o '<link name="ego/[^"]*"' <<<"$out" | wc -l)"
bare_ends="$(grep -o 'link="[^"]*"' <<<"$out" | grep -vc 'link="ego/')"
if [ "$links" -gt 0 ] && [ "$links" -eq "$prefixed" ] && [ "$bare_ends" -eq 0 ] && [[ "$out" == *'<robot name="ego"'* ]]; then
  echo "ok: mrzr: $links links, all prefixed 'ego/'"
else
  echo "FAILED: mrzr: $prefixed of $links links prefixed, $bare_ends joint ends not"; failed=1
fi
err="$(python3 "$script" "$root/urdf/rover7.urdf" ego 2>&1 >/dev/null)"; rc=$?
known="$(cd "$root/urdf" && ls *.urdf | sed 's/\.urdf$//' | paste -sd, | sed 's/,/, /g')"
expected="prefix_urdf: unknown model 'rover7' (no $root/urdf/rover7.urdf); known models: $known"
if [ $rc -eq 1 ] && [ "$err" = "$expected" ]; then
  echo "ok: unknown model: $err"
else
  echo "FAILED: unknown model gave exit $rc and: $err (expected: $expected)"; failed=1
fi
python3 "$script" "$root/urdf/mrzr.urdf" "bad/name" >/dev/null 2>&1; rc=$?
if [ $rc -eq 2 ]; then echo "ok: bad vehicle name exit 2"; else echo "FAILED: bad vehicle name exit $rc"; failed=1; fi
exit $failed
