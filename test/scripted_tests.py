"""What the scripted tests (run_main_job.py, run_fault_injection.py) share: the JUnit XML result,
one test case per (name, failure messages) pair, passed when the list is empty; waiting for
/clock; a free port for a private master."""
import os
import random
import signal
import socket
import subprocess
import sys
import time
from xml.sax.saxutils import escape


def clock_reaches(t, env, limit, process=None):
    """Waits (wall limit) until /clock on the master of `env` reaches `t` s; True if it did.
    False at once if `process` (a Popen) ends first."""
    code = ("import rospy, sys\n"
            "from rosgraph_msgs.msg import Clock\n"
            "rospy.init_node('scripted_test_clock_probe', anonymous=True, disable_signals=True)\n"
            "while rospy.wait_for_message('/clock', Clock, timeout=60).clock.to_sec() < float(sys.argv[1]):\n"
            "    pass\n")
    probe = subprocess.Popen([sys.executable, "-c", code, str(t)], env=env, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)
    deadline = time.time() + limit
    try:
        while time.time() < deadline:
            if probe.poll() is not None:
                return probe.returncode == 0
            if process is not None and process.poll() is not None:
                return False
            time.sleep(0.1)
        return False
    finally:
        if probe.poll() is None:
            probe.kill()
            probe.wait()


def free_port():
    """A TCP port for a test's private master that nothing holds now, below Linux's ephemeral
    range (32768-60999): a port from that range may be taken by any outgoing connection, and a
    test that starts its master twice on the port (the main job) once found it in use."""
    rng = random.Random()
    for _ in range(200):
        port = rng.randint(20000, 32000)
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
            try:
                s.bind(("0.0.0.0", port))
            except OSError:
                continue
            return port
    raise RuntimeError("no free TCP port in 20000-32000")


def stop_launch(launch):
    """Stops a roslaunch started in its own process group: SIGINT, SIGKILL after 40 s."""
    if launch.poll() is None:
        os.killpg(launch.pid, signal.SIGINT)
        try:
            launch.wait(timeout=40)
        except subprocess.TimeoutExpired:
            os.killpg(launch.pid, signal.SIGKILL)
            launch.wait()


def write_junit(result, suite, cases):
    """Writes `cases` [(name, [messages])] as test suite `suite` to `result` and prints a line per case."""
    failures = sum(1 for _n, m in cases if m)
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             '<testsuite name="%s" tests="%d" failures="%d" errors="0">' % (suite, len(cases), failures)]
    for n, msgs in cases:
        lines.append('  <testcase classname="%s" name="%s">' % (suite, n))
        if msgs:
            lines.append('    <failure message="%s">%s</failure>' % (escape(msgs[0][:200], {'"': "&quot;"}),
                                                                    escape("\n".join(msgs))))
        lines.append("  </testcase>")
    lines.append("</testsuite>")
    os.makedirs(os.path.dirname(os.path.abspath(result)), exist_ok=True)
    with open(result, "w") as f:
        f.write("\n".join(lines) + "\n")
    for n, msgs in cases:
        print("%s: %s" % (n, "FAILED: " + "; ".join(msgs) if msgs else "ok"))
