#!/usr/bin/env bash
# Every C++ source of the repository is formatted as .clang-format says (clang-format --dry-run:
# a file it would change is named with the first lines it would change); and the check sees a
# badly formatted file (a scratch copy of one source, reindented).
# usage: check_format.sh
set -u
root="$(cd "$(dirname "$0")/.." && pwd)"
command -v clang-format >/dev/null || { echo "FAILED: clang-format is not installed (tools/debian-packages.txt)"; exit 1; }
mapfile -t files < <(cd "$root" && find avsp_msgs avsp_terrain avsp_dynamics avsp_sensors include src test \
  -type f \( -name '*.cpp' -o -name '*.hpp' -o -name '*.h' \) | sort)
[ "${#files[@]}" -gt 100 ] || { echo "FAILED: found only ${#files[@]} C++ files under $root"; exit 1; }
failed=0
for f in "${files[@]}"; do
  if ! out="$(cd "$root" && clang-format --dry-run --Werror --style=file "$f" 2>&1)"; then
    echo "FAILED: $f is not formatted (clang-format -i --style=file $f):"; echo "$out" | head -6; failed=1
  fi
done
# The check itself: a copy with one line indented wrongly must be refused.
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
cp "$root/.clang-format" "$tmp/"
sed '0,/^  return/s//        return/' "$root/src/scenario_launch.cpp" > "$tmp/bad.cpp"
if (cd "$tmp" && clang-format --dry-run --Werror --style=file bad.cpp >/dev/null 2>&1); then
  echo "FAILED: a misindented copy of src/scenario_launch.cpp passed the check"; failed=1
fi
[ $failed = 0 ] && echo "ok: ${#files[@]} C++ files formatted as .clang-format says"
exit $failed
