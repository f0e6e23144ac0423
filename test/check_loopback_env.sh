#!/usr/bin/env bash
# Sourcing the workspace's setup.sh puts ROS on loopback unless the user named an address.
# usage: check_loopback_env.sh SETUP_SH
set -u
setup="$1"
probe() {  # probe VAR=VALUE...: ROS_IP|ROS_HOSTNAME after sourcing setup.sh in a clean environment
  env -i HOME="$HOME" PATH=/usr/bin:/bin "$@" bash -c 'set +u; . "$0" >/dev/null 2>&1; echo "${ROS_IP:-}|${ROS_HOSTNAME:-}"' "$setup"
}
failed=0
check() {  # check EXPECTED VAR=VALUE...
  local expected="$1"; shift
  local got; got="$(probe "$@")"
  if [ "$got" = "$expected" ]; then echo "ok: ${*:-(nothing set)} -> $got"
  else echo "FAILED: ${*:-(nothing set)}: ROS_IP|ROS_HOSTNAME = '$got', expected '$expected'"; failed=1; fi
}
check "127.0.0.1|"
check "|robot1" ROS_HOSTNAME=robot1
check "10.0.0.5|" ROS_IP=10.0.0.5
exit $failed
