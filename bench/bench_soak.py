#!/usr/bin/python3
"""Soak benchmark (issue 21, deliverable 6, "Bounded memory"): runs the reference team scenario
for an hour of sim time at the fastest pace the run allows (real_time_factor 0, the lockstep)
and samples every node's resident memory against sim time. Prints per node the RSS at the end
of the warm-up, at the end, and the least-squares slope after the warm-up in MB (10^6 B) per
sim hour. The issue's target is <= 5 MB/h per node. A benchmark: it prints, it asserts nothing.

Nodes are found as processes whose command line has `__name:=<node>` and whose environment has
this run's ROS_MASTER_URI (a private master on a free port), by scanning /proc: CI's minimal
Debian has no procps. RSS is VmRSS of /proc/<pid>/status; sim time is the latest /clock.

usage (with a workspace sourced, e.g. `. build/avsp/devel/setup.sh`; not installed, so run by python3):
  python3 bench/bench_soak.py [--duration S] [--warmup S] [--scenario FILE] [--period WALL_S] [--keep DIR]
    --duration  s of sim time (default 3600; shorter for quick runs)
    --warmup    s of sim time left out of the slope (default 300, capped at half the duration)
    --scenario  scenario file (default config/scenarios/reference_traverse.yaml), run with
                `duration` replaced
    --period    wall s between samples (default 1)
    --keep      write the run's results and a CSV of the samples (sim_t, node, rss_kB) there
"""
import argparse
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time

import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "test"))
from scripted_tests import free_port, stop_launch  # noqa: E402


def run_nodes(master_uri):
    """{node name: pid} of the processes started for the master at `master_uri`; a name is the
    node's namespace (ROS_NAMESPACE, how roslaunch passes it) and its `__name:=`."""
    nodes = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open("/proc/%s/cmdline" % entry, "rb") as f:
                args = f.read().split(b"\0")
            names = [a[len(b"__name:="):] for a in args if a.startswith(b"__name:=")]
            if not names:
                continue
            with open("/proc/%s/environ" % entry, "rb") as f:
                env = dict(v.split(b"=", 1) for v in f.read().split(b"\0") if b"=" in v)
        except OSError:  # gone, or not ours to read
            continue
        # roslaunch writes the master URI with a trailing '/'
        if env.get(b"ROS_MASTER_URI", b"").decode().rstrip("/") != master_uri.rstrip("/"):
            continue
        ns = env.get(b"ROS_NAMESPACE", b"").decode().strip("/")
        nodes[(ns + "/" if ns else "") + names[-1].decode()] = int(entry)
    return nodes


def rss_kb(pid):
    """VmRSS of `pid` in kB (as /proc reports it: KiB), None when the process is gone."""
    try:
        with open("/proc/%d/status" % pid) as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return None


def wait_for_port(port, limit):
    deadline = time.time() + limit
    while time.time() < deadline:
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return True
        time.sleep(0.2)
    return False


def slope_per_hour(samples):
    """Least-squares slope of [(t s, rss kB)] in MB per hour; None with fewer than 2 times."""
    n = len(samples)
    if n < 2:
        return None
    mt = sum(t for t, _ in samples) / n
    mr = sum(r for _, r in samples) / n
    stt = sum((t - mt) ** 2 for t, _ in samples)
    if stt <= 0.0:
        return None
    str_ = sum((t - mt) * (r - mr) for t, r in samples)
    return str_ / stt * 1024.0 / 1e6 * 3600.0  # kB (KiB) per s -> MB per h


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--duration", type=float, default=3600.0)
    p.add_argument("--warmup", type=float, default=300.0)
    p.add_argument("--scenario", default=os.path.join(ROOT, "config", "scenarios", "reference_traverse.yaml"))
    p.add_argument("--period", type=float, default=1.0)
    p.add_argument("--keep", default="")
    a = p.parse_args()
    if not (a.duration > 0.0 and a.duration < 1e7):
        p.error("--duration %g: must be in (0, 1e7) s of sim time" % a.duration)
    if not (0.0 <= a.warmup < a.duration):
        p.error("--warmup %g: must be >= 0 and below --duration %g s (the slope is fitted after it)"
                % (a.warmup, a.duration))
    if not (a.period > 0.0):
        p.error("--period %g: must be > 0 s (wall time between RSS samples)" % a.period)
    if not os.path.isfile(a.scenario):
        p.error("--scenario %s: not a file" % a.scenario)
    warmup = a.warmup

    tmp = tempfile.mkdtemp(prefix="avsp_bench_soak_")
    out_dir = os.path.abspath(a.keep) if a.keep else tmp
    with open(a.scenario) as f:
        doc = yaml.safe_load(f)
    doc["duration"] = a.duration
    scenario = os.path.join(tmp, os.path.splitext(os.path.basename(a.scenario))[0] + ".yaml")
    with open(scenario, "w") as f:
        yaml.safe_dump(doc, f)

    port = free_port()
    master_uri = "http://127.0.0.1:%d" % port
    os.environ.update(ROS_MASTER_URI=master_uri, ROS_IP="127.0.0.1")
    os.environ.pop("ROS_HOSTNAME", None)
    launch_file = os.path.join(ROOT, "launch", "reference_traverse.launch")
    log = open(os.path.join(tmp, "roslaunch.log"), "w")
    start = time.time()
    launch = subprocess.Popen(["roslaunch", "-p", str(port), launch_file, "scenario:=" + scenario,
                               "duration:=%g" % a.duration, "real_time_factor:=0",
                               "output_dir:=" + os.path.join(out_dir, "results")],
                              stdout=log, stderr=subprocess.STDOUT, preexec_fn=os.setsid)
    samples = {}  # node -> [(sim t, rss kB)]
    try:
        if not wait_for_port(port, 60):
            sys.exit("bench_soak: the master on port %d did not come up (roslaunch log: %s)" % (port, log.name))
        import rospy
        from rosgraph_msgs.msg import Clock
        clock = {"t": None}

        def on_clock(m):
            clock["t"] = m.clock.to_sec()
        rospy.init_node("bench_soak", anonymous=True, disable_signals=True)
        rospy.Subscriber("/clock", Clock, on_clock, queue_size=1)
        while launch.poll() is None:
            time.sleep(a.period)
            t = clock["t"]
            if t is None or t > a.duration:
                continue
            for node, pid in run_nodes(master_uri).items():
                if node.startswith("bench_soak"):
                    continue
                r = rss_kb(pid)
                if r is not None:
                    samples.setdefault(node, []).append((t, r))
    finally:
        stop_launch(launch)
        log.close()
    wall = time.time() - start
    last_t = max((s[-1][0] for s in samples.values() if s), default=0.0)

    print("bench_soak: %s, %.0f s of sim time (last sample at %.0f s) in %.0f s wall, roslaunch exit %s"
          % (os.path.basename(a.scenario), a.duration, last_t, wall, launch.returncode))
    print("bench_soak: RSS (VmRSS, MB = 10^6 B) at the warm-up end (first sample at or after %.0f s), at the "
          "end, and the least-squares slope after the warm-up; target <= 5 MB per sim hour" % warmup)
    print("%-28s %12s %12s %12s %8s" % ("node", "warm-up MB", "end MB", "MB/sim h", "samples"))
    for node in sorted(samples):
        s = samples[node]
        after = [x for x in s if x[0] >= warmup]
        mb = lambda kb: kb * 1024.0 / 1e6  # noqa: E731
        slope = slope_per_hour(after)
        print("%-28s %12s %12.1f %12s %8d" % (node, "%.1f" % mb(after[0][1]) if after else "-", mb(s[-1][1]),
                                               "%+.1f" % slope if slope is not None else "-", len(after)))
    if a.keep:
        with open(os.path.join(out_dir, "rss_samples.csv"), "w") as f:
            f.write("sim_t,node,rss_kB\n")
            for node in sorted(samples):
                for t, r in samples[node]:
                    f.write("%.3f,%s,%d\n" % (t, node, r))
        shutil.copy(log.name, os.path.join(out_dir, "roslaunch.log"))
    shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
