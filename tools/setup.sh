#!/usr/bin/env bash
# Installs the Debian packages listed in the given files (one name per line, '#' comments),
# skipping those already installed. Runs 'apt-get update' at most once, and only when
# something is missing. Uses sudo when not root.
set -euo pipefail
export PATH="/usr/bin:/bin:/usr/sbin:/sbin:${PATH}"
[ $# -ge 1 ] || { echo "usage: $0 PACKAGE_LIST [PACKAGE_LIST...]" >&2; exit 2; }

wanted=()
for list in "$@"; do
  [ -r "$list" ] || { echo "setup: cannot read package list '$list'" >&2; exit 1; }
  while read -r line; do
    name="${line%%#*}"; name="$(echo "$name" | tr -d '[:space:]')"
    [ -n "$name" ] && wanted+=("$name")
  done < "$list"
done

missing=()
for p in "${wanted[@]}"; do
  status="$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)"
  [ "$status" = "install ok installed" ] || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#wanted[@]} Debian packages already installed"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "setup: not root and no sudo; install as root: ${missing[*]}" >&2; exit 1; }
  SUDO="sudo"
fi
echo "setup: installing ${#missing[@]} missing packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q || { echo "setup: apt-get update failed" >&2; exit 1; }
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}" \
  || { echo "setup: apt-get install failed for: ${missing[*]}" >&2; exit 1; }
