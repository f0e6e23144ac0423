#!/usr/bin/python3
"""Master re-use (issue 22, deliverable 3): a second, different scenario on a master that has
just run another must run exactly as on a fresh master. Writes a JUnit XML result:

- first_run: FIRST (test/scenarios/fault_small.yaml: two vehicles, a deer, a lidar) runs for a
  few seconds on a private master and exits 0;
- second_run_same_master: SECOND (test/scenarios/reuse_b.yaml: another vehicle, no agents, no
  lidar) then runs on the same master and exits 0 (a stale ~vehicle_sensors/<v> of the first
  run stopped sensors_node and the run waited for start_gate's 300 s; stale ~agents loaded the
  first run's deer into a scenario without agents);
- same_as_fresh_master: SECOND's trajectories.csv (x, y, z, speed of every row) and its
  summary's vehicles and sample counts equal those of SECOND on a fresh master.

usage: run_master_reuse.py LAUNCH_FILE FIRST SECOND RESULT_XML [WALL_LIMIT_S]
"""
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scripted_tests import free_port, stop_launch, write_junit  # noqa: E402


def start_master(port, env):
    core = subprocess.Popen(["roscore", "-p", str(port)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, preexec_fn=os.setsid)
    deadline = time.time() + 30
    while time.time() < deadline:
        probe = subprocess.run(["rosparam", "get", "/rosversion"], env=env, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
        if probe.returncode == 0:
            return core
        time.sleep(0.3)
    stop_launch(core)
    raise RuntimeError("roscore on port %d did not start" % port)


def run(launch_file, scenario, duration, out, env, limit):
    """roslaunch of the scenario on the master of `env` (already running); its exit code, None on timeout."""
    log = open(out + ".log", "w")
    p = subprocess.Popen(["roslaunch", launch_file, "scenario:=" + scenario, "duration:=%g" % duration,
                          "real_time_factor:=0", "output_dir:=" + out], env=env, stdout=log,
                         stderr=subprocess.STDOUT, preexec_fn=os.setsid)
    try:
        return p.wait(timeout=limit)
    except subprocess.TimeoutExpired:
        return None
    finally:
        stop_launch(p)
        log.close()


def rows(path):
    """{(vehicle, t): "x,y,z,speed"} of a trajectories.csv."""
    out = {}
    with open(path) as f:
        header = f.readline().strip().split(",")
        cols = [header.index(c) for c in ("x", "y", "z", "speed")]
        for line in f:
            cells = line.strip().split(",")
            out[(cells[0], cells[1])] = ",".join(cells[c] for c in cols)
    return out


def summary_facts(path):
    """What must not depend on the master's history: vehicles, their samples, aborts, anomalies."""
    with open(path) as f:
        doc = json.load(f)
    return {
        "aborted": doc.get("aborted"),
        "anomalies": doc.get("anomalies"),
        "vehicles": [(v.get("name"), v.get("odometry_samples"), v.get("t_first"), v.get("t_last"))
                     for v in doc.get("vehicles", [])],
    }


def tail(out):
    try:
        with open(out + ".log") as f:
            return f.read()[-500:]
    except OSError:
        return "(no log)"


def main(argv):
    if len(argv) < 5:
        sys.stderr.write(__doc__)
        return 2
    launch_file, first, second, result = argv[1], os.path.abspath(argv[2]), os.path.abspath(argv[3]), argv[4]
    limit = float(argv[5]) if len(argv) > 5 else 180.0
    tmp = tempfile.mkdtemp(prefix="avsp_reuse_")
    cases = []
    masters = []
    try:
        def master():
            port = free_port()
            env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:%d" % port, ROS_IP="127.0.0.1")
            env.pop("ROS_HOSTNAME", None)
            masters.append(start_master(port, env))
            return env

        fresh = master()
        out_fresh = os.path.join(tmp, "second_fresh")
        rc = run(launch_file, second, 8.0, out_fresh, fresh, limit)
        stop_launch(masters.pop())
        if rc != 0:
            raise RuntimeError("SECOND on a fresh master: %s\n%s" % ("timeout" if rc is None else "exit %d" % rc,
                                                                     tail(out_fresh)))

        shared = master()
        out_first = os.path.join(tmp, "first")
        start = time.time()
        rc = run(launch_file, first, 4.0, out_first, shared, limit)
        print("run_master_reuse: FIRST %.1f s wall, exit %s" % (time.time() - start, rc))
        cases.append(("first_run", [] if rc == 0 else ["FIRST exited %s: %s" % (rc, tail(out_first))]))

        out_second = os.path.join(tmp, "second_reused")
        start = time.time()
        rc = run(launch_file, second, 8.0, out_second, shared, limit)
        print("run_master_reuse: SECOND after FIRST on the same master %.1f s wall, exit %s" % (time.time() - start, rc))
        cases.append(("second_run_same_master",
                      [] if rc == 0 else ["SECOND on the used master: %s: %s"
                                          % ("timeout" if rc is None else "exit %d" % rc, tail(out_second))]))

        msgs = []
        try:
            mine, ref = rows(os.path.join(out_second, "trajectories.csv")), rows(os.path.join(out_fresh, "trajectories.csv"))
            if len(ref) < 70:
                msgs.append("the fresh run has only %d trajectory rows" % len(ref))
            differ = sorted(k for k in set(ref) | set(mine) if ref.get(k) != mine.get(k))
            if differ:
                k = differ[0]
                msgs.append("%d of %d trajectory rows differ from the fresh master's; first %s: %s vs %s"
                            % (len(differ), len(ref), k, ref.get(k), mine.get(k)))
            print("run_master_reuse: %d trajectory rows compared, %d differ" % (len(ref), len(differ)))
            a, b = summary_facts(os.path.join(out_second, "summary.json")), summary_facts(
                os.path.join(out_fresh, "summary.json"))
            if a["aborted"] is not None:
                msgs.append("SECOND on the used master was aborted: %s" % a["aborted"])
            if a != b:
                msgs.append("summary differs from the fresh master's: %s vs %s" % (a, b))
        except Exception as e:  # noqa: BLE001
            msgs.append("results unreadable: %s" % e)
        cases.append(("same_as_fresh_master", msgs))
    except Exception:  # noqa: BLE001
        cases.append(("harness", [traceback.format_exc()]))
    finally:
        for core in masters:
            stop_launch(core)
        shutil.rmtree(tmp, ignore_errors=True)
    write_junit(result, "master_reuse", cases)
    return 0 if all(not m for _n, m in cases) else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
