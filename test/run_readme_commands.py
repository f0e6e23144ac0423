#!/usr/bin/python3
"""Every command in the READMEs, run (issue 22, item 7): a README example that does not run is a
failing test. Writes a JUnit XML result with one test case per command.

Commands are the lines of the READMEs' ```sh blocks (continuation lines joined) and the
inline `rosrun ...` / `roslaunch ...` spans of their prose. Each is matched, in order, against the
rules below; a command no rule matches fails (a new README example needs its rule here):

- NOT_RUN: commands this test cannot run, each with the reason and what covers it instead (the
  make targets are CI and the main job; the AVT-341 recipe needs GitHub; nft changes the host's
  firewall). They are listed in the result, not hidden.
- ENVIRONMENT: `export PATH=...`, `. install/setup.sh`: the environment this test runs in.
- ONE_SHOT: run to completion; exit 0 and, where given, the files it must write.
The commands of one ```sh block run in order on one private master (a `rosparam set` holds for the
next line), an inline span on a master of its own.

- LONG_RUNNING (nodes, launch files): started, and stopped before the next command; passed when it
  reaches its ready condition (a node registered, /clock past 1 s, ...) within its limit, is
  still running then, and printed no [ERROR], [FATAL], Traceback or "has died"; then stopped.

Substitutions, the same for every command: `gui:=true` / `rviz:=true` become false (RViz is not
part of the test set-up; `make screenshot` shows it), and the placeholder scenario `my.yaml`
(`/path/my.yaml`) is a copy of config/scenarios/reference_traverse_ci.yaml. Commands run in a
scratch folder (their relative outputs land there).

Also: a list parameter given as YAML text that is not valid YAML is refused, naming the key.

usage: run_readme_commands.py REPO_DIR RESULT_XML
"""
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scripted_tests import clock_reaches, free_port, write_junit  # noqa: E402

READMES = ["README.md", "avsp_msgs/README.md", "avsp_terrain/README.md", "avsp_dynamics/README.md",
           "avsp_sensors/README.md", "config/scenarios/README.md"]
ERROR_MARKS = ("[ERROR]", "[FATAL]", "Traceback", "has died")

NOT_RUN = [
    (r"^make (test|demo)\b", "the make targets are CI itself (make test) and the main job's run of "
                             "reference_traverse.launch (make demo: test main_job)"),
    (r"^make (demo-gui|screenshot|build|clean)\b", "make targets around the build and RViz; `make test` (CI) builds"),
    (r"^nft ", "changes the host's firewall (root); measured by hand (docs/design/avsp.md, network exposure)"),
    (r"^sudo apt-get install libtf-dev|avt_ws|CGoodin/avt_341|avt_341_stack\.launch",
     "the AVT-341 stack's recipe needs GitHub and its build (tests avt_341_contract and avt_341/route_check "
     "cover AVSP's side)"),
    (r"^rosrun avsp_terrain export_course$", "the tool's name in prose; README.md's `rosrun avsp_terrain "
                                             "export_course --out course.tif --soil-map soil.png` runs it"),
    (r"^export PATH=/usr/bin:\$PATH$", "ENV"),
    (r"^\. install/setup\.sh$", "ENV"),
]

# (pattern, ready condition, wall limit s); conditions: ("node", name), ("clock", t), ("nodes", k)
LONG_RUNNING = [
    (r"reference_traverse\.launch|scenario_launch my\.yaml --out my\.launch", ("clock", 1.0), 180),
    (r"team_dynamics\.launch", ("clock", 1.0), 180),
    (r"avt_341\.launch", ("clock", 1.0), 180),
    (r"team_description\.launch|demo\.launch", ("nodes_named", "robot_state_publisher", 4), 120),
    (r"rosrun avsp_terrain terrain_node", ("node", "/terrain_node"), 120),
    (r"rosrun avsp_dynamics lockstep_clock", ("node", "/lockstep_clock"), 60),
    (r"rosrun avsp environment_node", ("node", "/environment_node"), 60),
    (r"rosrun avsp v2v_radio_node", ("node", "/v2v_radio_node"), 60),
    (r"controller_node", ("node", "/{ns}/controller_node"), 60),
    (r"rosrun avsp run_recorder", ("node", "/run_recorder"), 60),
]

ONE_SHOT = [
    (r"rosrun avsp scenario_launch my\.yaml --check", []),
    (r"rosrun avsp_terrain export_course --out course\.tif --soil-map soil\.png", ["course.tif", "soil.png"]),
    (r"^rostopic pub -1 ", []),
    (r"^rosparam set /use_sim_time true$", []),
]


def readme_blocks(repo):
    """[(readme, [(line number, command)])]: each ```sh block, and each inline span, in README order."""
    out = []
    for readme in READMES:
        path = os.path.join(repo, readme)
        with open(path) as f:
            lines = f.read().split("\n")
        in_sh, pending, start, block = False, "", 0, []
        for n, line in enumerate(lines, 1):
            if line.startswith("```"):
                if in_sh and block:
                    out.append((readme, block))
                in_sh, block = not in_sh and line.strip() in ("```sh", "```bash"), []
                continue
            if in_sh:
                text = line.strip()
                if not pending and (not text or text.startswith("#")):
                    continue
                if not pending:
                    start = n
                if text.endswith("\\"):
                    pending += text[:-1] + " "
                    continue
                block.append((start, strip_comment(pending + text)))
                pending = ""
            else:
                for m in re.finditer(r"`((?:rosrun|roslaunch) [^`]+)`", line):
                    out.append((readme, [(n, m.group(1))]))
    return out


def strip_comment(cmd):
    """The command without a trailing shell comment (a '#' outside quotes after a blank)."""
    quote = None
    for i, c in enumerate(cmd):
        if quote:
            quote = None if c == quote else quote
        elif c in "'\"":
            quote = c
        elif c == "#" and i > 0 and cmd[i - 1] == " ":
            return cmd[:i].rstrip()
    return cmd.strip()


def substituted(cmd, scenario):
    cmd = re.sub(r"\b(gui|rviz):=true\b", r"\1:=false", cmd)
    cmd = cmd.replace("/path/my.yaml", scenario)
    return re.sub(r"(?<![\w/.])my\.yaml\b", scenario, cmd)


def is_synopsis(cmd):
    """A command form with placeholders (`scenario_node SCENARIO [options]`), not a command."""
    return bool(re.search(r"\[options\]|\b(SCENARIO|FILE|DIR)\b", cmd))


def registered_nodes(master_uri):
    """Every node that publishes, subscribes or serves something on the master."""
    import rosgraph
    try:
        state = rosgraph.Master("/readme_commands", master_uri=master_uri).getSystemState()
    except Exception:  # noqa: BLE001 - the master is not up yet
        return set()
    nodes = set()
    for group in state:
        for _topic, names in group:
            nodes.update(names)
    return nodes


def wait_ready(condition, env, limit, proc, cmd):
    deadline = time.time() + limit
    kind = condition[0]
    if kind == "clock":
        return clock_reaches(condition[1], env, limit, proc)
    while time.time() < deadline:
        if proc.poll() is not None:
            return False
        nodes = registered_nodes(env["ROS_MASTER_URI"])
        if kind == "node":
            ns = re.search(r"ROS_NAMESPACE=(\w+)", cmd)
            if condition[1].format(ns=ns.group(1) if ns else "") in nodes:
                return True
        elif kind == "nodes_named" and sum(1 for n in nodes if n.endswith(condition[1])) >= condition[2]:
            return True
        time.sleep(0.5)
    return False


def start_master(env):
    master = subprocess.Popen(["roscore", "-p", env["ROS_MASTER_URI"].rsplit(":", 1)[1]], env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, preexec_fn=os.setsid)
    deadline = time.time() + 30
    import rosgraph
    while time.time() < deadline:
        if rosgraph.is_master_online(env["ROS_MASTER_URI"]):
            return master
        time.sleep(0.2)
    raise RuntimeError("roscore did not come up")


def stop(proc, grace=20):
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGINT)
        try:
            proc.wait(timeout=grace)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def as_user(cmd, repo):
    """`cmd` in a user's shell as the README sets it up: Debian's python first, the install space's
    setup.sh (not the build's test environment, whose package path also holds the source tree,
    which makes `roslaunch avsp X.launch` ambiguous)."""
    return "export PATH=/usr/bin:$PATH; . '%s/install/setup.sh'; %s" % (repo, cmd)


def user_env(env):
    """The test's environment without the ROS paths of the build it runs in."""
    clean = {k: v for k, v in env.items()
             if not k.startswith(("ROS_PACKAGE_PATH", "CMAKE_PREFIX_PATH", "PYTHONPATH", "LD_LIBRARY_PATH",
                                  "PKG_CONFIG_PATH", "ROSLISP_PACKAGE_DIRECTORIES", "COLCON_PREFIX_PATH",
                                  "AMENT_PREFIX_PATH", "CATKIN_"))}
    return clean


def run_long(cmd, condition, limit, env, cwd):
    """Starts `cmd` on the block's master, waits for its ready condition, stops it."""
    log = os.path.join(cwd, "command.log")
    with open(log, "w") as out:
        proc = subprocess.Popen(["bash", "-c", cmd], cwd=cwd, env=env, stdout=out, stderr=subprocess.STDOUT,
                                preexec_fn=os.setsid)
        try:
            ready = wait_ready(condition, env, limit, proc, cmd)
            time.sleep(1.0)  # an error right after the ready condition still counts
            alive = proc.poll() is None
            with open(log) as f:
                text = f.read()  # what it printed before it was stopped (a stopped run says so)
        finally:
            stop(proc)
    msgs = []
    if not ready:
        msgs.append("not ready (%s) within %g s" % (" ".join(str(c) for c in condition), limit))
    if not alive:
        msgs.append("exited with %s before it was stopped" % proc.returncode)
    marks = [line for line in text.splitlines() if any(m in line for m in ERROR_MARKS)]
    if marks:
        msgs.append("printed: " + " | ".join(marks[:5]))
    if msgs:
        msgs.append("last output: " + " | ".join(text.strip().splitlines()[-8:]))
    return msgs


def run_one_shot(cmd, files, env, cwd):
    p = subprocess.run(["bash", "-c", cmd], cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                       universal_newlines=True, timeout=300)
    msgs = [] if p.returncode == 0 else ["exit %d: %s" % (p.returncode, p.stdout.strip()[-600:])]
    for f in files:
        path = os.path.join(cwd, f)
        if not os.path.isfile(path) or os.path.getsize(path) == 0:
            msgs.append("did not write " + f)
    return msgs


def bad_list_parameter(env, cwd, repo):
    """A list parameter given as YAML text must be valid YAML: exit 1 naming the key."""
    master = start_master(env)
    try:
        p = subprocess.run(["bash", "-c", as_user("rosrun avsp v2v_radio_node '_vehicles:=[m113, mrzr'", repo)],
                           cwd=cwd, env=env,
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True, timeout=60)
    finally:
        stop(master)
    if p.returncode != 1 or "~vehicles" not in p.stdout or "not a YAML list" not in p.stdout:
        return ["exit %d (want 1, naming ~vehicles): %s" % (p.returncode, p.stdout.strip()[-400:])]
    return []


def main(argv):
    if len(argv) != 3:
        sys.stderr.write(__doc__)
        return 2
    repo, result = os.path.abspath(argv[1]), argv[2]
    env = user_env(dict(os.environ, ROS_IP="127.0.0.1"))
    env.pop("ROS_HOSTNAME", None)
    if not os.path.isfile(os.path.join(repo, "install", "setup.sh")):
        sys.stderr.write("run_readme_commands: no %s/install/setup.sh: the READMEs' commands run from the install "
                         "space (colcon build)\n" % repo)
        write_junit(result, "readme_commands", [("install_space", ["no install/setup.sh (colcon build)"])])
        return 0
    scratch = tempfile.mkdtemp(prefix="avsp_readme_")
    scenario = os.path.join(scratch, "my.yaml")
    shutil.copy(os.path.join(repo, "config", "scenarios", "reference_traverse_ci.yaml"), scenario)
    cases, counts = [], {"run": 0, "environment": 0, "not run": 0, "synopsis": 0}
    try:
        for readme, block in readme_blocks(repo):
            master = None  # one master per block, started for its first command that runs
            try:
                for line, raw in block:
                    name = "%s:%d %s" % (readme, line, raw[:80])
                    if is_synopsis(raw):
                        counts["synopsis"] += 1
                        print("readme_commands: %s: a synopsis with placeholders, not run" % name)
                        continue
                    reason = next((why for pat, why in NOT_RUN if re.search(pat, raw)), None)
                    if reason == "ENV":
                        counts["environment"] += 1
                        print("readme_commands: %s: the environment this test runs in" % name)
                        continue
                    if reason:
                        counts["not run"] += 1
                        print("readme_commands: %s: not run: %s" % (name, reason))
                        continue
                    if master is None:
                        env["ROS_MASTER_URI"] = "http://127.0.0.1:%d" % free_port()
                        master = start_master(env)
                    cmd = as_user(substituted(raw, scenario), repo)
                    cwd = tempfile.mkdtemp(dir=scratch)
                    start = time.time()
                    long_rule = next(((c, lim) for pat, c, lim in LONG_RUNNING if re.search(pat, raw)), None)
                    shot_rule = next((files for pat, files in ONE_SHOT if re.search(pat, raw)), None)
                    if long_rule:
                        msgs = run_long(cmd, long_rule[0], long_rule[1], env, cwd)
                        # The next command gets a fresh master: a stopped run's nodes may leave
                        # registrations whose ports other processes then take.
                        stop(master)
                        master = None
                    elif shot_rule is not None:
                        msgs = run_one_shot(cmd, shot_rule, env, cwd)
                    else:
                        msgs = ["no rule of run_readme_commands.py says how to run this command (add one)"]
                    counts["run"] += 1
                    print("readme_commands: %s: %s (%.1f s)" % (
                        name, "ok" if not msgs else "FAILED: " + "; ".join(msgs), time.time() - start))
                    cases.append((re.sub(r"[^\w.:-]+", "_", name)[:120], msgs))
            finally:
                if master is not None:
                    stop(master)
        env["ROS_MASTER_URI"] = "http://127.0.0.1:%d" % free_port()
        cases.append(("bad_yaml_list_parameter", bad_list_parameter(env, scratch, repo)))
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    print("readme_commands: %d commands run, %d the environment, %d not run (reasons above), %d synopses"
          % (counts["run"], counts["environment"], counts["not run"], counts["synopsis"]))
    write_junit(result, "readme_commands", cases)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
