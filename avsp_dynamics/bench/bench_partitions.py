#!/usr/bin/python3
"""Partitions benchmark (issue 7). Prints two tables:

1. Real-time factor vs number of vehicles (default 4, 8, 16, 32, 64) with 1 and 2 dynamics
   partitions behind lockstep_clock, on the default course (600 m x 400 m, 0.1 m cells),
   deformable soil on, no sensors, no controllers: the vehicles (m113, mrzr, tracer_x, fed_alpha
   in turn) drive straight east in lanes 5.5 m apart from x = 400 m at throttle 0.4 (a latched
   command; ~command_timeout set long). Obstacles are off so that no start pose needs a
   clearance check. With 2 partitions the vehicles are split by cost as scenario `partitions: 2`
   does, and the partitions are peers (proxies and soil exchange on). The real-time factor is
   sim time / wall time between /clock = 1 s and the end (`--duration`, default 10 s), as
   lockstep_clock measures it (nothing else subscribes to /clock meanwhile): start-up (each
   partition builds the course) is not counted. The partitions step ahead of each other's
   latest exchanges while their vehicles are apart (dynamics_node ~step_ahead_intervals, default
   4, and lockstep_clock ~lookahead K + 1; the share of intervals is printed); `--step-ahead K` sets it (0: strict).
   While apart they also hold their soil changes back (sent with a later exchange); the share
   of exchanges that carried soil is printed too.
   The "ceiling" column is what two processes can give on this machine at all: the two halves
   run at the same time as two independent runs (no peers, one clock each), and the slower one's
   real-time factor over the single process's is the speed-up 2 partitions would reach with no
   synchronisation and no exchange at all. `--repeat N` runs the three N times in turn and prints
   the best real-time factor of each (the host's speed drifts from run to run and only ever
   slows a run), with each round's own speed-up.
2. Lockstep synchronisation overhead: two partitions with one fed_alpha each on flat gravel;
   per 10 ms interval the wall time a partition spends waiting for the clock and its peer (from
   its own log). The faster partition's wait also holds the load difference, so the figure is
   the lesser of the two waits: the round trip done -> clock -> tick plus the exchange. On the
   loopback, and (`--veth`, needs root) with partition p2 in a second network namespace joined
   by a veth pair, as in test/two_hosts.py. Each link twice: strict (every interval waits for
   the peer's exchange: the figure is the round trip) and stepping ahead (the two vehicles are
   10 m apart: the wait left is what the one-interval slack does not absorb).

usage: . build/avsp/devel/setup.sh && python3 avsp_dynamics/bench/bench_partitions.py
       [--vehicles 4,8,16,32,64] [--duration 10] [--veth] [--sync-only] [--rtf-only] [--step-ahead K]
       [--repeat N]
(AVSP_BENCH_KEEP_LOGS=1 keeps each run's roslaunch log and prints its path.)
"""
import argparse
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test"))
from netns_pair import create, delete, inside  # noqa: E402

MODELS = ["m113", "mrzr", "tracer_x", "fed_alpha"]
COST = {"m113": 11.0, "mrzr": 5.0, "tracer_x": 5.0, "fed_alpha": 5.0}  # 1 + wheels + road wheels


def balanced(vehicles, count):
    """Greedy by cost, as avsp::scenario::balancedPartitions."""
    order = sorted(range(len(vehicles)), key=lambda i: -COST[vehicles[i][1]])
    load = [0.0] * count
    home = [0] * len(vehicles)
    for i in order:
        p = load.index(min(load))
        load[p] += COST[vehicles[i][1]]
        home[i] = p
    return [[vehicles[i] for i in range(len(vehicles)) if home[i] == p] for p in range(count)]


SYNC_INTERVAL = [0.01]  # s, --sync-interval
REPEAT = [1]  # --repeat: rounds per vehicle count (best of them is printed)
STEP_AHEAD = [4]  # dynamics_node ~step_ahead_intervals (--step-ahead); lockstep_clock ~lookahead is K + 1


def node_xml(name, vehicles, partition, peers, terrain, machine_attr=""):
    vlist = ", ".join("{name: %s, model: %s, x: %.1f, y: %.1f, yaw: 0.0}" % (n, m, x, y)
                      for n, m, x, y in vehicles)
    peers_xml = '    <rosparam param="peers">[%s]</rosparam>\n' % ", ".join(peers) if peers else ""
    return ('  <node pkg="avsp_dynamics" type="dynamics_node" name="%s" required="true" output="screen"%s>\n'
            '    <rosparam param="vehicles">[%s]</rosparam>\n'
            '    <param name="partition" value="%s"/>\n%s'
            '    <param name="sync_interval" value="%g"/>\n'
            '    <param name="step_ahead_intervals" value="%d"/>\n'
            '    <param name="publish_clock" value="false"/>\n'
            '    <param name="wait_for_command" value="true"/>\n'
            '    <param name="command_timeout" value="3600.0"/>\n'
            '    <param name="obstacles" value="false"/>\n'
            '    <param name="config_dir" value="$(find avsp)/config/vehicles"/>\n'
            '    <param name="soils_file" value="$(find avsp)/config/soils.yaml"/>\n%s'
            '  </node>\n' % (name, machine_attr, vlist, partition, peers_xml, SYNC_INTERVAL[0],
                            STEP_AHEAD[0], terrain))


def launch_xml(parts, duration, terrain, host_split=False):
    names = ["p%d" % (k + 1) for k in range(len(parts))]
    out = ['<?xml version="1.0"?>\n<launch>\n', '  <arg name="host_a" default="true"/>\n',
           '  <arg name="host_b" default="true"/>\n', '  <param name="/use_sim_time" value="true"/>\n']
    a = ['  <node pkg="avsp_dynamics" type="lockstep_clock" name="clock" required="true" output="screen">\n'
         '    <rosparam param="partitions">[%s]</rosparam>\n'
         '    <param name="duration" value="%g"/>\n    <param name="timeout" value="60.0"/>\n'
         '    <param name="sync_interval" value="%g"/>\n'
         '    <param name="lookahead" value="%d"/>\n'
         '  </node>\n' % (", ".join(names), duration, SYNC_INTERVAL[0], STEP_AHEAD[0] + 1)]
    b = []
    for k, vehicles in enumerate(parts):
        peers = [n for n in names if n != names[k]]
        xml = node_xml("dynamics_" + names[k], vehicles, names[k], peers, terrain)
        (b if host_split and k == 1 else a).append(xml)
    if host_split:
        out += ['  <group if="$(arg host_a)">\n'] + a + ['  </group>\n', '  <group if="$(arg host_b)">\n'] + b + \
               ['  </group>\n']
    else:
        out += a + b
    out.append('</launch>\n')
    return "".join(out)


# The measuring side: a rospy node that latches a command to every vehicle and times /clock.
PROBE = r'''
import sys, time, rospy
from avsp_msgs.msg import DriveCommand
from rosgraph_msgs.msg import Clock
names = sys.argv[1].split(",")
start_at, end_at = float(sys.argv[2]), float(sys.argv[3])
rospy.init_node("bench_probe", disable_signals=True)
pubs = [rospy.Publisher("/%s/cmd_drive" % n, DriveCommand, queue_size=1, latch=True) for n in names]
for p in pubs:
    c = DriveCommand(); c.throttle = 0.4; p.publish(c)
# Stay until the run has started (the latched commands delivered), then leave the clock alone:
# lockstep_clock measures the pace itself (a subscriber at 100 Hz would take CPU from the run).
started = []
sub = rospy.Subscriber("/clock", Clock, lambda m: started.append(1) if m.clock.to_sec() > 0.0 else None)
deadline = time.time() + float(sys.argv[4])
while time.time() < deadline and not started:
    time.sleep(0.05)
sub.unregister()
print("STARTED" if started else "NOT STARTED")
'''

WAIT_RE = re.compile(r"partition '(\w+)': (\d+) intervals to t = ([\d.]+) s; per interval ([\d.]+) us stepping, "
                     r"([\d.]+) us waiting for the clock and peers, ([\d.]+) us exchanging with them; (\d+) stepped ahead"
                     r"[^;\n]*; our soil changes sent in (\d+) of (\d+) exchanges")


def env_for(setup, port, ip="127.0.0.1"):
    return {"HOME": os.environ.get("HOME", "/root"), "PATH": "/usr/bin:/bin:/usr/sbin:/sbin",
            "ROS_IP": ip, "ROS_MASTER_URI": "http://%s:%d" % (ip, port), "ROS_HOME": "/tmp/avsp_bench_ros",
            "ROSCONSOLE_STDOUT_LINE_BUFFERED": "1"}


def stop(p):
    if p.poll() is None:
        try:
            os.killpg(p.pid, signal.SIGINT)
            p.wait(timeout=20)
        except Exception:  # noqa: BLE001
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()


def run_layout(setup, parts, duration, terrain, port, timeout):
    """One run on this host: (real-time factor, {partition: (stepping us, waiting us)})."""
    with tempfile.NamedTemporaryFile("w", suffix=".launch", delete=False) as f:
        f.write(launch_xml(parts, duration, terrain))
        path = f.name
    log = tempfile.NamedTemporaryFile("w+", suffix=".log", delete=False)
    env = env_for(setup, port)
    launch = subprocess.Popen(["bash", "-c", ". %s && exec roslaunch -p %d %s" % (setup, port, path)], env=env,
                              stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    names = ",".join(v[0] for p in parts for v in p)
    try:
        probe = subprocess.run(["bash", "-c", ". %s && exec python3 -c '%s' %s 1.0 %g %g" %
                                (setup, PROBE.replace("'", "'\\''"), names, duration, timeout)],
                               env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True,
                               timeout=timeout + 60)
        launch.wait(timeout=timeout)
    finally:
        stop(launch)
    log.seek(0)
    text = log.read()
    log.close()
    if os.environ.get("AVSP_BENCH_KEEP_LOGS"):
        print("(log kept: %s)" % log.name)
    else:
        os.remove(log.name)
    os.remove(path)
    m = re.search(r"from t = 1 s: [\d.]+ s wall, real-time factor ([\d.]+)", text)
    rtf = float(m.group(1)) if m else float("nan")
    waits = {}
    for w in WAIT_RE.finditer(text):
        waits[w.group(1)] = (float(w.group(4)), float(w.group(5)), float(w.group(6)),
                             100.0 * float(w.group(7)) / max(1.0, float(w.group(2))),
                             100.0 * float(w.group(8)) / max(1.0, float(w.group(9))))
    if rtf != rtf or (len(parts) > 1 and len(waits) < len(parts)):
        sys.stderr.write("run failed:\n%s\n%s\n" % (probe.stdout[-2000:], text[-4000:]))
    return rtf, waits


COURSE = ('    <param name="course_cell_size" value="0.1"/>\n')
FLAT = ('    <param name="flat_soil" value="gravel"/>\n    <param name="flat_size" value="40.0"/>\n')


def rtf_table(setup, counts, duration):
    print("Real-time factor vs vehicles, default course, deformable soil on, sensors off "
          "(%g s of sim time from t = 1 s, sync interval %g s, %s)" %
          (duration, SYNC_INTERVAL[0], "stepping ahead up to %d intervals" % STEP_AHEAD[0] if STEP_AHEAD[0] else "strict"))
    print("| vehicles | 1 partition | 2 partitions | speed-up | ceiling | 2 partitions: stepping/waiting/exchange, us per "
          "interval (intervals stepped ahead; exchanges carrying soil) |")
    print("|---:|---:|---:|---:|---:|---|")
    sys.stdout.flush()
    port = 12000  # a new master port per run, clear of the sync table's (116xx, 117xx)
    for n in counts:
        vehicles = [("v%02d" % k, MODELS[k % 4], 400.0, 20.0 + 5.5 * k) for k in range(n)]
        halves = balanced(vehicles, 2)
        rounds = []  # (1 partition, 2 partitions, their waits, slower half alone), one per round
        for _ in range(REPEAT[0]):
            port += 1
            one, _ = run_layout(setup, [vehicles], duration, COURSE, port, 600.0)
            port += 1
            two, waits = run_layout(setup, halves, duration, COURSE, port, 600.0)
            alone = [float("nan"), float("nan")]

            def half(k, port_k):
                alone[k], _ = run_layout(setup, [halves[k]], duration, COURSE, port_k, 600.0)
            port += 2
            threads = [threading.Thread(target=half, args=(k, port - 1 + k)) for k in range(2)]
            for t in threads:
                t.start()
            for t in threads:
                t.join()
            rounds.append((one, two, waits, min(alone)))
        # Best of the rounds for each layout (the host's speed drifts between runs; a run is only
        # ever slowed by it), and the rounds' own ratios for the spread.
        one = max(r[0] for r in rounds)
        best = max(rounds, key=lambda r: r[1])
        two, waits = best[1], best[2]
        ceiling = max(r[3] for r in rounds) / one if one > 0 else float("nan")
        speedup = "%.2f" % (two / one if one > 0 else float("nan"))
        if len(rounds) > 1:
            ratios = sorted(r[1] / r[0] for r in rounds if r[0] > 0)
            speedup += " (rounds %s)" % ", ".join("%.2f" % x for x in ratios)
        detail = ", ".join("%s %.0f/%.0f/%.0f (%.0f%%; %.0f%%)" % (p, *waits[p]) for p in sorted(waits))
        print("| %d | %.2fx | %.2fx | %s | %.2f | %s |" % (n, one, two, speedup, ceiling, detail))
        sys.stdout.flush()


def sync_loopback(setup, duration):
    parts = [[("a", "fed_alpha", -10.0, -5.0)], [("b", "fed_alpha", -10.0, 5.0)]]
    rtf, waits = run_layout(setup, parts, duration, FLAT, 11690, 300.0)
    return rtf, waits


def sync_veth(setup, duration):
    """p2 in a second network namespace joined by a veth pair (root)."""
    if os.geteuid() != 0:
        return None, "needs root"
    k = os.getpid() % 200 + 20
    ns_a, ns_b = "avsp_ba%d" % os.getpid(), "avsp_bb%d" % os.getpid()
    veth_a, veth_b = "avba%d" % (os.getpid() % 100000), "avbb%d" % (os.getpid() % 100000)
    ip_a, ip_b = "10.232.%d.1" % k, "10.232.%d.2" % k
    port = 11700 + k
    procs = []
    path = None
    try:
        failed = create(ns_a, ns_b, veth_a, veth_b, ip_a, ip_b)
        if failed:
            return None, "network set-up failed: " + failed
        parts = [[("a", "fed_alpha", -10.0, -5.0)], [("b", "fed_alpha", -10.0, 5.0)]]
        with tempfile.NamedTemporaryFile("w", suffix=".launch", delete=False) as f:
            f.write(launch_xml(parts, duration, FLAT, host_split=True))
            path = f.name
        master = "http://%s:%d" % (ip_a, port)
        logs = []

        def on_host(ns, ip, script):
            env = env_for(setup, port, ip)
            env["ROS_MASTER_URI"] = master
            log = tempfile.NamedTemporaryFile("w+", suffix=".log", delete=False)
            logs.append(log)
            p = subprocess.Popen(inside(ns) + ["bash", "-c", ". %s && %s" % (setup, script)], env=env, stdout=log,
                                 stderr=subprocess.STDOUT, start_new_session=True)
            procs.append(p)
            return p
        on_host(ns_a, ip_a, "exec roscore -p %d" % port)
        time.sleep(2.0)
        on_host(ns_a, ip_a, "exec roslaunch --wait %s host_a:=true host_b:=false" % path)
        on_host(ns_b, ip_b, "exec roslaunch --wait %s host_a:=false host_b:=true" % path)
        env = env_for(setup, port, ip_a)
        env["ROS_MASTER_URI"] = master
        probe = subprocess.run(inside(ns_a) + ["bash", "-c", ". %s && exec python3 -c '%s' a,b 1.0 %g 300" %
                                               (setup, PROBE.replace("'", "'\\''"), duration)],
                               env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True,
                               timeout=400)
        procs[1].wait(timeout=300)  # host A's roslaunch ends with the clock (required)
        time.sleep(1.0)
        for p in reversed(procs):
            stop(p)
        waits = {}
        for log in logs:
            log.seek(0)
            for w in WAIT_RE.finditer(log.read()):
                waits[w.group(1)] = (float(w.group(4)), float(w.group(5)), float(w.group(6)),
                             100.0 * float(w.group(7)) / max(1.0, float(w.group(2))),
                             100.0 * float(w.group(8)) / max(1.0, float(w.group(9))))
        text = ""
        for log in logs:
            log.seek(0)
            text += log.read()
        m = re.search(r"from t = 1 s: [\d.]+ s wall, real-time factor ([\d.]+)", text)
        return (float(m.group(1)) if m else float("nan")), waits
    finally:
        for p in reversed(procs):
            stop(p)
        if path:
            os.remove(path)
        delete(ns_a, ns_b)


def print_sync(name, result):
    rtf, waits = result
    if rtf is None:
        print("| %s | (%s) | | | | |" % (name, waits))
        return
    if len(waits) < 2:
        print("| %s | (no timing in the partitions' logs) | | | | |" % name)
        return
    wait = min(w[1] for w in waits.values())
    step = max(w[0] for w in waits.values())
    exch = max(w[2] for w in waits.values())
    ahead = min(w[3] for w in waits.values())
    print("| %s | %.0f | %.0f | %.0f | %.0f%% | %.2fx |" % (name, wait, exch, step, ahead, rtf))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vehicles", default="4,8,16,32,64")
    ap.add_argument("--duration", type=float, default=10.0)
    ap.add_argument("--veth", action="store_true")
    ap.add_argument("--sync-only", action="store_true")
    ap.add_argument("--rtf-only", action="store_true")
    ap.add_argument("--sync-interval", type=float, default=0.01, help="s, lockstep_clock's interval")
    ap.add_argument("--step-ahead", type=int, default=4, help="dynamics_node ~step_ahead_intervals (0: strict)")
    ap.add_argument("--repeat", type=int, default=1,
                    help="rounds per vehicle count (1, 2 partitions and the ceiling in turn); the best of each is "
                         "printed, with each round's speed-up")
    args = ap.parse_args()
    SYNC_INTERVAL[0] = args.sync_interval
    STEP_AHEAD[0] = args.step_ahead
    REPEAT[0] = max(1, args.repeat)
    devel = os.environ.get("CMAKE_PREFIX_PATH", "").split(":")[0]
    setup = os.path.join(devel, "setup.sh")
    if not os.path.exists(setup):
        sys.stderr.write("source the workspace first (. build/avsp/devel/setup.sh)\n")
        return 2
    if not args.sync_only:
        rtf_table(setup, [int(v) for v in args.vehicles.split(",")], args.duration)
    if not args.rtf_only:
        print("\nLockstep synchronisation, 2 partitions x 1 fed_alpha on flat gravel, 10 ms intervals (%g s)"
              % args.duration)
        print("| link | sync wait, us/interval | exchange, us/interval | stepping, us/interval | stepped ahead | "
              "real-time factor |")
        print("|---|---:|---:|---:|---:|---:|")
        for ahead in (0, args.step_ahead):
            STEP_AHEAD[0] = ahead
            mode = "stepping ahead up to %d" % ahead if ahead else "strict"
            print_sync("loopback, " + mode, sync_loopback(setup, args.duration))
            if args.veth:
                print_sync("veth (two network namespaces), " + mode, sync_veth(setup, args.duration))
    return 0


if __name__ == "__main__":
    sys.exit(main())
