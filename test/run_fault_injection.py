#!/usr/bin/python3
"""Fault injection (issue 21): a run must stop, keep what it made and say why. Runs
scenario_node on SCENARIO once per case and writes a JUnit XML result, one test case each:

- kill_<node>: SIGKILL of one node of each type 3 s of sim time into the run. scenario_node must
  exit 5 within the wall limit (the issue's target is 5 s; the measured time is printed), and
  summary.json, written by this run, must say "aborted" naming that node;
- kill_run_recorder: SIGKILL of the recorder itself: the run ends, exit 5, no summary;
- interrupt: SIGINT of scenario_node (a terminal's Ctrl-C): exit 130, summary.json "aborted"
  by /run_recorder ("interrupted by SIGINT") with every result file written;
- sigint_each_node: SIGINT to every node at once (as roslaunch does on Ctrl-C): each exits by
  itself within the wall limit (the issue's target is 1 s; the measured times are printed);
- startup_failure: SIGKILL of sensors_node as soon as it runs, while it loads (before the clock
  starts; a start-up error --check cannot foresee): exit 5 naming /sensors at sim time 0, long
  before start_gate's 300 s timeout.

usage: run_fault_injection.py SCENARIO RESULT_XML [WALL_LIMIT_S [CASE,CASE...]]
(the last argument runs only the named cases, e.g. kill_sensors_node,interrupt)
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
from scripted_tests import clock_reaches, free_port, write_junit  # noqa: E402

# (case, the node's name as roslaunch passes it (__name:=...), its resolved name)
KILLS = [
    ("terrain_node", "terrain", "/terrain"),
    ("dynamics_node", "dynamics", "/dynamics"),
    ("sensors_node", "sensors", "/sensors"),
    ("environment_node", "environment", "/environment"),
    ("v2v_radio_node", "v2v_radio", "/v2v_radio"),
    ("agents_node", "agents", "/agents"),
    ("controller_node", "controller", "/alpha/controller"),
    ("v2v_broadcaster", "v2v_broadcaster", "/bravo/v2v_broadcaster"),
    ("robot_state_publisher", "robot_state_publisher", "/alpha/robot_state_publisher"),
    ("static_frame_publisher", "map_to_odom", "/map_to_odom"),
]


def find_node(name):
    import roslib.packages
    found = roslib.packages.find_node("avsp", name)
    return found[0] if found else None


def pid_of(name, ns, env):
    """The pid of the process roslaunch started for node `name` in namespace `ns` ("" = global)
    on this master (roslaunch passes __name:= and the group's namespace as ROS_NAMESPACE)."""
    # /proc, not pgrep: a minimal Debian (CI's clean machine) has no procps.
    wanted = ("__name:=" + name).encode()
    for pid in (d for d in os.listdir("/proc") if d.isdigit()):
        try:
            with open("/proc/%s/cmdline" % pid, "rb") as f:
                if wanted not in f.read().split(b"\0"):
                    continue
            with open("/proc/%s/environ" % pid, "rb") as f:
                environ = dict(e.split(b"=", 1) for e in f.read().split(b"\0") if b"=" in e)
        except OSError:
            continue
        if environ.get(b"ROS_MASTER_URI", b"").decode() != env["ROS_MASTER_URI"]:
            continue
        if environ.get(b"ROS_NAMESPACE", b"/").decode().strip("/") == ns:
            return int(pid)
    return None


class Run:
    """scenario_node on `scenario`, results in `out`, on the master of `env`."""

    def __init__(self, scenario, out, env):
        self.out = out
        self.started = time.time()
        self.log = open(out + ".log", "w")
        self.p = subprocess.Popen([find_node("scenario_node"), scenario, "--real-time-factor", "1",
                                   "--output-dir", out], env=env, stdout=self.log, stderr=subprocess.STDOUT,
                                  preexec_fn=os.setsid)

    def wait(self, limit):
        """scenario_node's exit code, or None if it had not ended after `limit` s (then it is killed)."""
        try:
            return self.p.wait(timeout=limit)
        except subprocess.TimeoutExpired:
            os.killpg(self.p.pid, signal.SIGKILL)
            self.p.wait()
            return None
        finally:
            self.log.close()

    def summary(self):
        path = os.path.join(self.out, "summary.json")
        if not os.path.isfile(path) or os.path.getmtime(path) < self.started:
            return None
        with open(path) as f:
            return json.load(f)

    def tail(self):
        with open(self.out + ".log") as f:
            return f.read()[-600:]


def main(argv):
    if len(argv) < 3:
        sys.stderr.write(__doc__)
        return 2
    scenario, result = os.path.abspath(argv[1]), argv[2]
    limit = float(argv[3]) if len(argv) > 3 else 15.0
    only = set(argv[4].split(",")) if len(argv) > 4 else None

    def wanted(case):
        return only is None or case in only
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:%d" % port, ROS_IP="127.0.0.1")
    env.pop("ROS_HOSTNAME", None)
    tmp = tempfile.mkdtemp(prefix="avsp_fault_")
    core = subprocess.Popen(["roscore", "-p", str(port)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, preexec_fn=os.setsid)
    cases = []

    def started(run, case):
        if clock_reaches(3.0, env, 120, run.p):
            return True
        run.wait(1)
        cases.append((case, ["the run did not reach 3 s of sim time: " + run.tail()]))
        return False

    try:
        # roslaunch refuses a master whose /run_id it cannot read yet: wait until it answers.
        deadline = time.time() + 60
        while subprocess.run(["rosparam", "get", "/run_id"], env=env, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL).returncode != 0:
            if time.time() > deadline:
                raise RuntimeError("roscore on port %d did not start" % port)
            time.sleep(0.2)
        for case, name, resolved in KILLS + [("run_recorder", "run_recorder", "/run_recorder")]:
            if not wanted("kill_" + case):
                continue
            run = Run(scenario, os.path.join(tmp, case), env)
            if not started(run, "kill_" + case):
                continue
            ns = resolved.split("/")[1] if resolved.count("/") > 1 else ""
            pid = pid_of(name, ns, env)
            if pid is None:
                run.wait(1)
                cases.append(("kill_" + case, ["no process for node " + resolved]))
                continue
            killed = time.time()
            os.kill(pid, signal.SIGKILL)
            rc = run.wait(limit)
            took = time.time() - killed
            print("run_fault_injection: SIGKILL of %s: scenario_node exit %s after %.2f s" % (resolved, rc, took))
            msgs = []
            if rc is None:
                msgs.append("the run did not end within %g s of the SIGKILL of %s" % (limit, resolved))
            elif rc != 5:
                msgs.append("scenario_node exited %d, expected 5 (run aborted)" % rc)
            summary = run.summary()
            if case == "run_recorder":
                if summary is not None:
                    msgs.append("a summary.json appeared though its writer was killed")
            elif summary is None:
                msgs.append("no summary.json written by this run: " + run.tail())
            elif not isinstance(summary.get("aborted"), dict) or summary["aborted"].get("node") != resolved:
                msgs.append("summary.json 'aborted' is %r, expected node %s" % (summary.get("aborted"), resolved))
            cases.append(("kill_" + case, msgs))

        run = Run(scenario, os.path.join(tmp, "interrupt"), env) if wanted("interrupt") else None
        if run and started(run, "interrupt"):
            os.killpg(run.p.pid, signal.SIGINT)
            rc = run.wait(limit)
            msgs = [] if rc == 130 else ["scenario_node exited %s, expected 130" % rc]
            summary = run.summary()
            aborted = summary.get("aborted") if summary else None
            if not isinstance(aborted, dict) or aborted.get("node") != "/run_recorder" or \
                    aborted.get("reason") != "interrupted by SIGINT":
                msgs.append("summary.json 'aborted' is %r" % aborted)
            for f in ["summary.json", "trajectories.csv", "trajectories.png", "ruts.png", "gaps.png"]:
                if not os.path.isfile(os.path.join(run.out, f)):
                    msgs.append("no %s after the interrupt" % f)
            if summary and summary.get("sim_time_end", 0.0) < 3.0:
                msgs.append("the partial results end at %s s, before the interrupt" % summary.get("sim_time_end"))
            cases.append(("interrupt", msgs))

        # SIGINT of every node at once (what roslaunch sends on Ctrl-C): each must exit by itself;
        # sensors_node once ignored it and every run waited 15 s for roslaunch's SIGTERM.
        run = Run(scenario, os.path.join(tmp, "sigint_each_node"), env) if wanted("sigint_each_node") else None
        if run and started(run, "sigint_each_node"):
            pids = {}
            for _case, name, resolved in KILLS + [("run_recorder", "run_recorder", "/run_recorder")]:
                ns = resolved.split("/")[1] if resolved.count("/") > 1 else ""
                pid = pid_of(name, ns, env)
                if pid is not None:
                    pids[resolved] = pid
            sent = time.time()
            for pid in pids.values():
                os.kill(pid, signal.SIGINT)
            left, took = dict(pids), {}
            while left and time.time() - sent < limit:
                for node, pid in list(left.items()):
                    try:
                        os.kill(pid, 0)
                        with open("/proc/%d/stat" % pid) as f:
                            if f.read().split(")")[-1].split()[0] == "Z":  # exited, not yet reaped
                                raise ProcessLookupError
                    except (ProcessLookupError, FileNotFoundError):
                        took[node] = time.time() - sent
                        del left[node]
                time.sleep(0.01)
            run.wait(limit)
            print("run_fault_injection: SIGINT to every node: " +
                  ", ".join("%s %.2f s" % (n, t) for n, t in sorted(took.items(), key=lambda kv: kv[1])))
            msgs = ["%s still running %g s after SIGINT" % (n, limit) for n in left]
            if len(pids) != len(KILLS) + 1:
                msgs.append("found %d of %d nodes" % (len(pids), len(KILLS) + 1))
            cases.append(("sigint_each_node", msgs))

        if wanted("startup_failure"):
            # sensors_node killed while it loads (before the clock starts): the start gate would
            # wait 300 s for it, and the run once never ended.
            run = Run(scenario, os.path.join(tmp, "startup_failure"), env)
            pid, deadline = None, time.time() + 60
            while pid is None and time.time() < deadline and run.p.poll() is None:
                pid = pid_of("sensors", "", env)
                time.sleep(0.02)
            msgs = []
            if pid is None:
                run.wait(1)
                msgs.append("sensors_node did not start: " + run.tail())
            else:
                killed = time.time()
                os.kill(pid, signal.SIGKILL)
                rc = run.wait(limit)
                print("run_fault_injection: SIGKILL of /sensors while it starts: exit %s after %.2f s" %
                      (rc, time.time() - killed))
                if rc != 5:
                    msgs.append("scenario_node exited %s, expected 5: %s" % (rc, run.tail()))
                summary = run.summary()
                aborted = summary.get("aborted") if summary else None
                if not isinstance(aborted, dict) or aborted.get("node") != "/sensors":
                    msgs.append("summary.json 'aborted' is %r, expected node /sensors" % aborted)
                elif aborted.get("sim_time") != 0:
                    msgs.append("the run had started (sim time %s): not a start-up failure" % aborted.get("sim_time"))
            cases.append(("startup_failure", msgs))
    except Exception:  # noqa: BLE001 - a harness failure is a failed case, with its traceback
        cases.append(("harness", ["the fault-injection harness failed:\n" + traceback.format_exc()]))
    finally:
        try:
            os.killpg(core.pid, signal.SIGINT)
        except ProcessLookupError:
            pass
        core.wait()
        shutil.rmtree(tmp, ignore_errors=True)

    write_junit(result, "fault_injection", cases)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
