#!/usr/bin/env bash
# AVSP command line behind the Makefile: set up, build, run the demo, run the tests.
#
#   bash tools/avsp.sh demo [--gui]  install what is missing, build, run the reference traverse headless
#                                    (results/reference_traverse/; --gui: with RViz at wall-clock pace)
#   bash tools/avsp.sh test          install what is missing, build, run every test, print "N passed, N failed"
#   bash tools/avsp.sh build         install what is missing and build only
#   bash tools/avsp.sh screenshot    build, then the reference traverse in RViz under Xvfb -> results/rviz_reference_traverse.png
#
# Every step says what it does; the first failing step is named and the script exits non-zero.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
# catkin's Python helpers must run on Debian's interpreter, not a pyenv shim.
export PATH="/usr/bin:/bin:/usr/sbin:/sbin:${PATH}"

step() { printf '\n== avsp: %s\n' "$*"; }
fail() { printf '\n!! avsp: step failed: %s\n' "$*" >&2; exit 1; }

usage() { sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//'; }

do_setup() {
  step "install Debian packages (skips what is installed)"
  bash tools/setup.sh "$@" || fail "install Debian packages (tools/setup.sh)"
}

do_build() {
  step "build with colcon (build/, install/)"
  # Unset environment from other workspaces so the build sees only /usr and this tree.
  unset CMAKE_PREFIX_PATH ROS_PACKAGE_PATH AMENT_PREFIX_PATH COLCON_PREFIX_PATH || true
  colcon build \
    --cmake-args -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCATKIN_ENABLE_TESTING=ON \
    || fail "colcon build (see log/latest_build)"
}

cmd="${1:-}"
[ $# -gt 0 ] && shift
case "$cmd" in
  build)
    do_setup tools/debian-packages.txt; do_build ;;
  demo)
    gui=0
    for a in "$@"; do
      case "$a" in
        --gui) gui=1 ;;
        *) fail "demo: unknown option '$a' (known: --gui)" ;;
      esac
    done
    if [ $gui = 1 ]; then do_setup tools/debian-packages.txt tools/debian-packages-gui.txt; else do_setup tools/debian-packages.txt; fi
    do_build
    step "run the reference traverse (scripts/run_demo.sh -> results/reference_traverse/)"
    set +u; . install/setup.sh; set -u
    AVSP_GUI=$gui bash scripts/run_demo.sh || fail "demo run (exit code $?)"
    step "demo finished successfully" ;;
  test)
    do_setup tools/debian-packages.txt; do_build
    step "run the tests (colcon test)"
    rm -rf build/avsp/test_results
    # rostest starts its own master; loopback addresses keep it independent of whether this
    # host's name resolves (it does not in minimal containers and chroots).
    unset ROS_HOSTNAME ROS_MASTER_URI
    export ROS_IP=127.0.0.1
    # colcon test exits 0 even when tests fail; failures are counted from the XML below.
    colcon test --event-handlers console_direct+ --return-code-on-test-failure \
      || echo "colcon test reported failures; counting them from the XML results"
    step "count test results (build/*/test_results)"
    python3 tools/count_test_results.py build ;;
  screenshot)
    do_setup tools/debian-packages.txt tools/debian-packages-gui.txt; do_build
    step "RViz screenshot under Xvfb (scripts/rviz_screenshot.sh)"
    set +u; . install/setup.sh; set -u
    bash scripts/rviz_screenshot.sh results/rviz_reference_traverse.png || fail "RViz screenshot" ;;
  ""|-h|--help|help)
    usage ;;
  *)
    usage; fail "unknown command '$cmd'" ;;
esac
