#!/usr/bin/env bash
# The shipped geomagnetic model is what tools/wmm_cof_to_geographiclib.py makes of NOAA's file:
# converting the committed WMM2025.COF gives avsp_sensors/data/magnetic/wmm2025.wmm and
# wmm2025.wmm.cof byte for byte; a COF with a coefficient line missing is refused, naming it.
# usage: check_wmm_files.sh
set -u
root="$(cd "$(dirname "$0")/.." && pwd)"
data="$root/avsp_sensors/data/magnetic"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
failed=0
python3 "$root/tools/wmm_cof_to_geographiclib.py" "$data/WMM2025.COF" "$tmp" || failed=1
for f in wmm2025.wmm wmm2025.wmm.cof; do
  if cmp "$tmp/$f" "$data/$f"; then echo "ok: $f reproduced"; else echo "FAILED: $f differs from the conversion"; failed=1; fi
done
sed '5d' "$data/WMM2025.COF" > "$tmp/missing_line.COF"  # degree 2 order 1
if out="$(python3 "$root/tools/wmm_cof_to_geographiclib.py" "$tmp/missing_line.COF" "$tmp/bad" 2>&1)"; then
  echo "FAILED: a COF without degree 2 order 1 was converted"; failed=1
elif [[ "$out" != *"missing terms (n, m) [(2, 1)]"* ]]; then
  echo "FAILED: the refusal does not name the missing term: $out"; failed=1
else
  echo "ok: refused: $out"
fi
exit $failed
