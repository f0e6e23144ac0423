#!/usr/bin/python3
"""The main job end to end on the shortened reference scenario, and scenario_launch's refusal
of bad scenario files. Writes a JUnit XML result with one test case per check:

- bad_scenario_*: scenario_launch --check on a bad file (unknown controller type, missing key,
  unknown model, a vehicle inside a building; what only the nodes once refused: an unknown
  sensor key or lidar preset, a start time beyond ROS time, a looping agent on two points, a
  vehicle file with a negative mass) exits 1 and its message names the file and the key path;
- launch_refuses_bad_scenario: `roslaunch reference_traverse.launch scenario:=<bad file>` exits 1
  with the message naming the file and key, and starts no node (the launch file validates the
  scenario while roslaunch loads it);
- generated_launch: reference_traverse.launch (scenario_node) wrote the run's launch file into the
  results folder;
- run_ends: the run ends by itself (run_recorder exits at `duration` s of sim time) within the
  wall-clock limit, and cleanly: run_recorder and scenario_node end their roslaunch with a
  SIGINT, so no "REQUIRED process [...] has died" banner is printed;
- results: summary.json, trajectories.png, ruts.png and gaps.png exist, written by this run,
  and summary.json has every vehicle of the scenario, is not aborted and counts no anomalies
  (overspeed, airborne, non-finite samples);
- plausible_motion: in trajectories.csv no vehicle goes faster than 1.05 x its model's governed
  drivetrain.max_speed, nor rises or falls faster than 2 m/s between samples (a vehicle set down
  overlapping the ground or a building was once thrown 5 m up at 12 m/s, governed 2 m/s);
- partitions_same_trajectories: the same scenario with `partitions: 2` (two dynamics_node
  processes behind lockstep_clock, the sensors in the lockstep) for 10 s writes the same
  trajectories.csv rows (x, y, z, speed) as the single-process run up to 9.9 s, and in both
  runs every vehicle's odometry_samples is one per odometry instant (a repeat of time 0 at
  start-up once counted twice in the partitioned run: 2002 samples, not 2001).
- echo_standard_topics: on a third run at wall-clock pace, every topic of a standard message type
  (not avsp_msgs) that the nodes publish is decoded as `rostopic echo` decodes it, `rostopic
  echo -n1` prints an odometry message, and the main job's standard types are all among them
  (issue 23, item 7: the Python message packages).

- rviz_shows_the_run: on that run, the RViz configuration scenario_launch wrote beside the
  launch file subscribes only topics the run publishes, and has a display for every lidar and
  radar cloud, controller path and odometry it publishes (issue 22, item 5).

A tree without run_recorder fails run_ends (the run has no end and no results without it).

usage: run_main_job.py SCENARIO RESULT_XML [DURATION_S] [WALL_LIMIT_S]
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scripted_tests import clock_reaches, free_port, stop_launch, write_junit  # noqa: E402


def find_node(name):
    import roslib.packages
    found = roslib.packages.find_node("avsp", name)
    return found[0] if found else None


def run(cmd, env, timeout):
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True, env=env,
                       timeout=timeout)
    return p.returncode, p.stdout, p.stderr


def bad_scenario_cases(scenario, env, tmp):
    """Edits of the good scenario and the key each must be refused with."""
    with open(scenario) as f:
        good = yaml.safe_load(f)
    cases = []

    def edit(name, key, change):
        doc = yaml.safe_load(yaml.safe_dump(good))
        change(doc)
        path = os.path.join(tmp, name + ".yaml")
        with open(path, "w") as f:
            yaml.safe_dump(doc, f)
        cases.append((name, path, key))

    edit("bad_controller", "vehicles[2].controller.type: unknown 'foo'",
         lambda d: d["vehicles"][2]["controller"].update(type="foo"))
    edit("missing_key", "geodetic_reference: missing key", lambda d: d.pop("geodetic_reference"))
    edit("unknown_model", "vehicles[0].model: unknown model 'rover7'", lambda d: d["vehicles"][0].update(model="rover7"))
    edit("negative_speed", "paths.traverse[1].speed: negative speed",
         lambda d: d["paths"]["traverse"][1].update(speed=-1.0))
    # The staging area's first building spans x 53-67 m, y 218.5-227.5 m.
    edit("inside_building", "vehicles[1].start: 'mrzr' starts inside building",
         lambda d: d["vehicles"][1]["start"].update(x=60.0, y=223.0))
    # Issue 21, finding 4: what the nodes refuse at start-up, --check and the generator refuse
    # too, through the nodes' own parsers.
    edit("unknown_sensor_key", "vehicles[2].sensors (as sensors_node reads it for 'fed_alpha'): "
         "parameter ~vehicle_sensors/fed_alpha/lidar/colour is not a known key",
         lambda d: d["vehicles"][2]["sensors"]["lidar"].update(colour="red"))
    edit("unknown_lidar_preset", "vehicles[3].sensors (as sensors_node reads it for 'tracer_x'): "
         "parameter ~vehicle_sensors/tracer_x/lidar/preset: lidarPreset: unknown preset 'VLP-99'",
         lambda d: d["vehicles"][3]["sensors"]["lidar"].update(preset="VLP-99"))
    edit("start_utc_2200", "time.start_utc: 2200-10-15T15:00:00Z must be between 1970 and 2106 (ROS time)",
         lambda d: d["time"].update(start_utc="2200-10-15T15:00:00Z"))
    # The magnetometers' World Magnetic Model 2025 is valid 2025.0-2030.0: a later run date is
    # refused by --check as by sensors_node at start-up.
    edit("start_utc_after_the_magnetic_model", "time.start_utc 2031-03-01T12:00:00Z with the vehicles' magnetometers: "
         "~sensors/magnetometer/model 'wmm2025' on ~date '2031-03-01'",
         lambda d: d["time"].update(start_utc="2031-03-01T12:00:00Z"))
    edit("looping_agent_on_two_points", "agents[0].path: a moving looping agent needs at least 3 points, got 2",
         lambda d: d["agents"][0].update(loop=True, path=[[95.0, 232.0], [97.0, 252.0]]))
    exe = find_node("scenario_launch")
    # A vehicle folder with a negative chassis mass, for a one-partition scenario: --check once
    # never loaded the vehicle files unless the scenario had partitions.
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    bad_root = os.path.join(tmp, "bad_vehicle_folder")
    shutil.copytree(os.path.join(root, "config"), os.path.join(bad_root, "config"))
    shutil.copytree(os.path.join(root, "urdf"), os.path.join(bad_root, "urdf"))
    urdf = os.path.join(bad_root, "urdf", "mrzr.urdf")
    with open(urdf) as f:
        text = f.read()
    with open(urdf, "w") as f:
        f.write(text.replace('<mass value="770"/>', '<mass value="-770"/>', 1))
    edit("negative_mass_vehicle_file", "vehicles[1].model: 'mrzr': ", lambda d: None)
    config_dirs = {"negative_mass_vehicle_file": os.path.join(bad_root, "config")}
    results = []
    for name, path, key in cases:
        extra = ["--config-dir", config_dirs[name]] if name in config_dirs else []
        rc, out, err = run([exe, path, "--check"] + extra, env, 120)
        msg = []
        if rc != 1:
            msg.append("exit code %d, expected 1" % rc)
        if (path + ": " + key) not in err:
            msg.append("stderr does not name '%s: %s': %s" % (path, key, err.strip()))
        results.append(("bad_scenario_" + name, msg))
    # roslaunch itself refuses it (reference_traverse.launch validates while it loads): exit 1,
    # the message naming the file and key, no node started (issue 22, item 6).
    path, key = next((p, k) for n, p, k in cases if n == "missing_key")
    launch_file = os.path.join(root, "launch", "reference_traverse.launch")
    launch_env = dict(env, ROS_MASTER_URI="http://127.0.0.1:%d" % free_port())
    rc, out, err = run(["roslaunch", launch_file, "scenario:=" + path], launch_env, 120)
    msg = [] if rc == 1 else ["roslaunch exited %d on a bad scenario, expected 1" % rc]
    if (path + ": " + key) not in out + err:
        msg.append("roslaunch's output does not name '%s: %s': %s" % (path, key, (out + err).strip()[-600:]))
    if "process[" in out:
        msg.append("a node was started: " + " | ".join(l for l in out.splitlines() if "process[" in l))
    results.append(("launch_refuses_bad_scenario", msg))
    return results


def run_launch(args, env, limit):
    """roslaunch with `args` in its own process group: its exit code, or None if it did not end
    within `limit` s (wall; then it is stopped)."""
    launch = subprocess.Popen(["roslaunch"] + args, env=env, preexec_fn=os.setsid)
    try:
        return launch.wait(timeout=limit)
    except subprocess.TimeoutExpired:
        return None
    finally:
        stop_launch(launch)


def trajectory_rows(path, until):
    """{(vehicle, t): "x,y,z,speed"} of trajectories.csv for t < until. The distance column is
    left out: run_recorder integrates it over the samples it received, and at real-time factor
    0 it can miss a vehicle's first samples while its connections form."""
    rows = {}
    with open(path) as f:
        header = f.readline().strip().split(",")
        cols = [header.index(c) for c in ("x", "y", "z", "speed")]
        for line in f:
            cells = line.strip().split(",")
            if len(cells) > 2 and float(cells[1]) < until:
                rows[(cells[0], cells[1])] = ",".join(cells[c] for c in cols)
    return header, rows


def plausible_motion_case(trajectories, models, config_dir):
    """Failure messages for samples of trajectories.csv beyond what the vehicles can do."""
    msgs = []
    governed = {}
    for vehicle, model in models.items():
        with open(os.path.join(config_dir, "vehicles", model + ".yaml")) as f:
            governed[vehicle] = float(yaml.safe_load(f)["drivetrain"]["max_speed"])
    last = {}
    with open(trajectories) as f:
        header = f.readline().strip().split(",")
        iv, it, iz, isp = (header.index(c) for c in ("vehicle", "t", "z", "speed"))
        for line in f:
            cells = line.strip().split(",")
            v, t, z, speed = cells[iv], float(cells[it]), float(cells[iz]), float(cells[isp])
            if v in governed and speed > 1.05 * governed[v]:
                msgs.append("%s at %.1f s: %.2f m/s, governed %.2f m/s" % (v, t, speed, governed[v]))
            if v in last and t > last[v][0]:
                rate = (z - last[v][1]) / (t - last[v][0])
                if abs(rate) > 2.0:
                    msgs.append("%s at %.1f s: z changes at %.2f m/s" % (v, t, rate))
            last[v] = (t, z)
    return msgs[:20]


def partitioned_case(scenario, reference, env, port, tmp, launch_file, limit):
    """The scenario with `partitions: 2` for 10 s: its trajectories must equal the single-process
    run's over those 10 s, row for row (issue 7: same answer, any layout)."""
    with open(scenario) as f:
        doc = yaml.safe_load(f)
    doc["partitions"] = 2
    path = os.path.join(tmp, "partitioned.yaml")
    with open(path, "w") as f:
        yaml.safe_dump(doc, f)
    out = os.path.join(tmp, "results", "partitioned")
    env2 = dict(env, ROS_MASTER_URI="http://127.0.0.1:%d" % (port + 1))
    start = time.time()
    rc = run_launch(["-p", str(port + 1), launch_file, "scenario:=" + path, "duration:=10", "real_time_factor:=0",
                     "output_dir:=" + out], env2, limit)
    print("run_main_job: partitioned run %.1f s wall for 10 s of sim time" % (time.time() - start))
    if rc != 0:
        return ["the partitioned run did not end cleanly (%s)" % ("timeout" if rc is None else "exit %d" % rc)]
    try:
        _h, mine = trajectory_rows(os.path.join(out, "trajectories.csv"), 9.95)
        _h, ref = trajectory_rows(reference, 9.95)
    except Exception as e:  # noqa: BLE001
        return ["trajectories unreadable: %s" % e]
    msgs = []
    if len(ref) < 4 * 99:
        msgs.append("the reference run has only %d rows before t = 9.95 s" % len(ref))
    common = [k for k in ref if k in mine]
    if len(common) < 4 * 98:
        msgs.append("only %d rows in both runs before t = 9.95 s" % len(common))
    differ = [k for k in common if mine[k] != ref[k]]
    if differ:
        k = sorted(differ)[0]
        msgs.append("%d of %d trajectory rows differ between 1 and 2 partitions; first %s: %s vs %s"
                    % (len(differ), len(common), k, ref[k], mine[k]))
    print("run_main_job: partitioned run: %d trajectory rows (x, y, z, speed) compared, %d differ"
          % (len(common), len(differ)))
    msgs += sample_counts_case(os.path.join(os.path.dirname(reference), "summary.json"),
                               os.path.join(out, "summary.json"))
    return msgs

# Topics whose messages come only on events, so that a short window may see none: the ROS log
# (every node's, rosgraph_msgs/Log; its class is the package's that /clock's Clock comes from).
EVENT_TOPICS = {"/rosout", "/rosout_agg"}
# Standard types the main job's nodes publish for certain (a run without them is not the main job).
EXPECTED_TYPES = {"nav_msgs/Odometry", "sensor_msgs/NavSatFix", "sensor_msgs/Imu", "sensor_msgs/MagneticField",
                  "sensor_msgs/PointCloud2", "sensor_msgs/JointState", "rosgraph_msgs/Clock", "tf2_msgs/TFMessage",
                  "visualization_msgs/MarkerArray"}


def published_topics(master_uri):
    """[(topic, type)] of the topics with at least one publisher on the master."""
    import rosgraph
    master = rosgraph.Master("/run_main_job_echo", master_uri=master_uri)
    publishers = {t for t, nodes in master.getSystemState()[0] if nodes}
    return sorted((t, ty) for t, ty in master.getTopicTypes() if t in publishers)


ECHO_PROBE = r"""
import sys, threading, time
import rospy, rostopic
# What `rostopic echo` does for each topic (rostopic.get_topic_class: the message class from the
# topic's type, roslib.message.get_message_class; it fails with "Cannot load message class for
# [nav_msgs/Odometry]" without its Python package), subscribed to all at once in one process.
topics, window = sys.argv[1].split(","), float(sys.argv[2])
rospy.init_node("run_main_job_echo_probe", anonymous=True, disable_signals=True)
got, lock = {}, threading.Lock()
for t in topics:
    try:
        cls, _real, _fn = rostopic.get_topic_class(t)
    except Exception as e:  # rostopic's own error: the class does not load
        print("FAIL %s %s" % (t, str(e).replace("\n", " ")))
        continue
    if cls is None:
        print("FAIL %s no message class" % t)
        continue
    def cb(msg, t=t):
        with lock:
            got.setdefault(t, type(msg)._type)
    rospy.Subscriber(t, cls, cb, queue_size=1)
deadline = time.time() + window
while time.time() < deadline and len(got) < len(topics):
    time.sleep(0.2)
for t in topics:
    if t in got:
        print("OK %s" % t)
"""


def echo_probe(topics, env, window):
    """{topic: None if a message was decoded, else why not}: ECHO_PROBE on all `topics`."""
    p = subprocess.run([sys.executable, "-c", ECHO_PROBE, ",".join(topics), str(window)], stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, universal_newlines=True, env=env, timeout=window + 120)
    result = {t: "no message decoded within %g s" % window for t in topics}
    for line in p.stdout.splitlines():
        parts = line.split(" ", 2)
        if len(parts) >= 2 and parts[1] in result:
            result[parts[1]] = None if parts[0] == "OK" else (parts[2] if len(parts) > 2 else "failed")
    return result


def rviz_topics_check(rviz_file, published):
    """Issue 22, item 5: the run's RViz configuration (scenario_launch writes it beside the launch
    file) subscribes only topics the run publishes, and has a display for every lidar and radar
    cloud, controller path and odometry the run publishes."""
    if not os.path.isfile(rviz_file):
        return ["no " + rviz_file]
    with open(rviz_file) as f:
        config = yaml.safe_load(f)
    wanted, stack = set(), [config]
    while stack:
        n = stack.pop()
        if isinstance(n, list):
            stack.extend(n)
        elif isinstance(n, dict):
            for k, v in n.items():
                if k in ("Topic", "Marker Topic", "Image Topic") and isinstance(v, str):
                    wanted.add(v)
                else:
                    stack.append(v)
    have = {t for t, _ty in published}
    msgs = ["%s: a display for %s, which no node of the run publishes" % (rviz_file, t) for t in sorted(wanted - have)]
    drawable = {t for t in have if t.endswith(("/avt_341/points", "/radar/points", "/controller/path",
                                               "/avt_341/odometry"))}
    msgs += ["%s: no display for %s" % (rviz_file, t) for t in sorted(drawable - wanted)]
    if not msgs:
        print("run_main_job: %s shows %d topics, all published; %d clouds, paths and odometries, all shown"
              % (os.path.basename(rviz_file), len(wanted), len(drawable)))
    return msgs


def echo_case(scenario, env, port, tmp, launch_file, limit, rviz_msgs):
    """Issue 23, item 7: on a run of the scenario at wall-clock pace, every topic of a standard
    type (any package but avsp_msgs) that the run's nodes publish is decoded as `rostopic echo`
    decodes it (rostopic.get_topic_class, one process for all), and the literal
    `rostopic echo -n1` prints the odometry the issue named (a set-up without Debian's
    python3-nav-msgs answered 'Cannot load message class for [nav_msgs/Odometry]')."""
    out = os.path.join(tmp, "results", "echo")
    env3 = dict(env, ROS_MASTER_URI="http://127.0.0.1:%d" % (port + 2))
    launch = subprocess.Popen(["roslaunch", "-p", str(port + 2), launch_file, "scenario:=" + scenario,
                               "duration:=600", "real_time_factor:=1", "output_dir:=" + out],
                              env=env3, preexec_fn=os.setsid, stdout=subprocess.DEVNULL)
    start = time.time()
    try:
        # Every node up and publishing: the vehicles' sensors run from the first odometry on.
        if not clock_reaches(3.0, env3, limit, launch):
            return ["/clock did not reach 3 s"]
        published = published_topics(env3["ROS_MASTER_URI"])
        rviz_msgs[:] = (rviz_topics_check(os.path.join(out, os.path.splitext(os.path.basename(scenario))[0] + ".rviz"),
                                           published))
        topics = [(t, ty) for t, ty in published if not ty.startswith("avsp_msgs/") and t not in EVENT_TOPICS]
        msgs = []
        missing = EXPECTED_TYPES - {ty for _t, ty in topics}
        if missing:
            msgs.append("no topic of type %s in the run" % ", ".join(sorted(missing)))
        results = echo_probe([t for t, _ty in topics], env3, 60.0)
        types = dict(topics)
        for t, why in sorted(results.items()):
            if why:
                msgs.append("%s (%s): %s" % (t, types[t], why))
        odometry = sorted(t for t, ty in topics if ty == "nav_msgs/Odometry")
        if odometry:
            p = subprocess.run(["rostopic", "echo", "-n1", odometry[0]], stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, universal_newlines=True, env=env3, timeout=120)
            if p.returncode != 0 or "pose:" not in p.stdout:
                msgs.append("rostopic echo -n1 %s: exit %d: %s" % (odometry[0], p.returncode, p.stdout.strip()[-300:]))
        print("run_main_job: %d standard-type topics (%d types) decoded as rostopic echo does, %d failed; "
              "rostopic echo -n1 %s; %.1f s wall"
              % (len(topics), len(set(types.values())), sum(1 for w in results.values() if w),
                 odometry[0] if odometry else "(no odometry)", time.time() - start))
        return msgs
    finally:
        stop_launch(launch)

def sample_counts_case(reference_summary, partitioned_summary):
    """Every odometry instant is one sample, however long start-up took (dynamics_node repeats
    the odometry of time 0 until its controllers answer; a repeat once counted): in both runs,
    n - 1 samples span t_last - t_first at one whole rate, the same in both."""
    msgs = []
    try:
        with open(reference_summary) as f:
            ref = json.load(f)
        with open(partitioned_summary) as f:
            mine = json.load(f)
    except Exception as e:  # noqa: BLE001
        return ["summaries unreadable: %s" % e]
    rates = {}
    for label, doc in (("single-process", ref), ("partitioned", mine)):
        for v in doc["vehicles"]:
            n, t0, t1 = v["odometry_samples"], v["t_first"], v["t_last"]
            if n < 2 or t1 <= t0:
                msgs.append("%s run: %s has %s samples over %s-%s s" % (label, v["name"], n, t0, t1))
                continue
            rate = (n - 1) / (t1 - t0)
            rates.setdefault(v["name"], []).append(rate)
            if abs(rate - round(rate)) > 1e-6 * rate:
                msgs.append("%s run: %s has %d odometry samples over %.3f-%.3f s: %.4f per second, not a whole "
                            "rate (a repeated instant counted?)" % (label, v["name"], n, t0, t1, rate))
    for name, r in sorted(rates.items()):
        if len(r) == 2 and abs(r[0] - r[1]) > 1e-6 * r[0]:
            msgs.append("%s: odometry at %.4f Hz single-process, %.4f Hz partitioned" % (name, r[0], r[1]))
    print("run_main_job: odometry sample counts: %s" % ", ".join(
        "%s %s Hz" % (name, "/".join("%.4f" % x for x in r)) for name, r in sorted(rates.items())))
    return msgs


def main(argv):
    if len(argv) < 3:
        sys.stderr.write(__doc__)
        return 2
    scenario, result = os.path.abspath(argv[1]), argv[2]
    duration = float(argv[3]) if len(argv) > 3 else 30.0
    limit = float(argv[4]) if len(argv) > 4 else 600.0
    with open(scenario) as f:
        scenario_vehicles = yaml.safe_load(f)["vehicles"]
    vehicles = [v["name"] for v in scenario_vehicles]
    models = {v["name"]: v["model"] for v in scenario_vehicles}
    config_dir = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "config")
    name = os.path.splitext(os.path.basename(scenario))[0]
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:%d" % port, ROS_IP="127.0.0.1")
    env.pop("ROS_HOSTNAME", None)
    cases = []
    tmp = tempfile.mkdtemp(prefix="avsp_main_job_")
    try:
        cases += bad_scenario_cases(scenario, env, tmp)

        out = os.path.join(tmp, "results", name)
        start = time.time()
        # By path: with both the source tree and install/ on ROS_PACKAGE_PATH the name is ambiguous.
        launch_file = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "launch",
                                   "reference_traverse.launch")
        log_path = os.path.join(tmp, "run.log")
        log = open(log_path, "w")
        launch = subprocess.Popen(["roslaunch", "-p", str(port), launch_file,
                                   "scenario:=" + scenario, "duration:=%g" % duration, "real_time_factor:=0",
                                   "output_dir:=" + out], env=env, preexec_fn=os.setsid, stdout=log,
                                  stderr=subprocess.STDOUT)
        recorder = find_node("run_recorder")
        generated = os.path.join(out, name + ".launch")
        try:
            if recorder:
                try:
                    rc = launch.wait(timeout=limit)
                    msgs = [] if rc == 0 else ["roslaunch exited with %d" % rc]
                    # A run that finished ends both launches cleanly (run_recorder's and
                    # scenario_node's SIGINT): no "REQUIRED process [...] has died" banner.
                    with open(log_path) as f:
                        text = f.read()
                    if "has died" in text:
                        msgs.append("a finished run printed roslaunch's 'has died' banner: " +
                                    " | ".join(l for l in text.splitlines() if "has died" in l))
                    cases.append(("run_ends", msgs))
                except subprocess.TimeoutExpired:
                    cases.append(("run_ends", ["the run did not end within %g s (wall)" % limit]))
            else:
                # The main job ends and writes its results only through run_recorder: without it
                # there is nothing to check, and that is a failure, not a weaker test.
                cases.append(("run_ends", ["run_recorder is not built (rospack finds no avsp/run_recorder)"]))
        finally:
            stop_launch(launch)
            log.close()
            with open(log_path) as f:
                sys.stdout.write(f.read())
        print("run_main_job: %.1f s wall for %g s of sim time" % (time.time() - start, duration))
        cases.append(("generated_launch", [] if os.path.isfile(generated) else ["no " + generated]))
        if recorder:  # (else run_ends failed above)
            msgs = []
            for f in ["summary.json", "trajectories.png", "ruts.png", "gaps.png"]:
                p = os.path.join(out, f)
                if not os.path.isfile(p) or os.path.getsize(p) == 0:
                    msgs.append("missing or empty: " + p)
                elif os.path.getmtime(p) < start:
                    msgs.append("older than the run: " + p)
            try:
                with open(os.path.join(out, "summary.json")) as f:
                    summary = json.load(f)
                entries = summary.get("vehicles") if isinstance(summary, dict) else None
                if isinstance(entries, list) and all(isinstance(e, dict) for e in entries):
                    names = {e.get("name") for e in entries}
                else:
                    names = set()
                    msgs.append("summary.json has no 'vehicles' list of objects (run_recorder writes one)")
                for v in vehicles:
                    if v not in names:
                        msgs.append("summary.json has no vehicle " + v)
                if not isinstance(summary, dict) or "aborted" not in summary:
                    msgs.append("summary.json has no 'aborted' entry")
                elif summary["aborted"] is not None:
                    msgs.append("the run was aborted: %s" % summary["aborted"])
                if summary.get("anomalies") != 0:
                    msgs.append("summary.json counts %s anomalies: %s" % (
                        summary.get("anomalies"), [(e.get("name"), e.get("anomalies")) for e in entries or []]))
            except Exception as e:  # noqa: BLE001 - any reason is a failure to report
                msgs.append("summary.json unreadable: %s" % e)
            cases.append(("results", msgs))
            trajectories = os.path.join(out, "trajectories.csv")
            cases.append(("plausible_motion", plausible_motion_case(trajectories, models, config_dir)
                          if os.path.isfile(trajectories) else ["no " + trajectories]))
            if duration >= 10.0:
                cases.append(("partitions_same_trajectories",
                              partitioned_case(scenario, os.path.join(out, "trajectories.csv"), env, port, tmp,
                                               launch_file, limit)))
        rviz_msgs = ["the run did not reach 3 s of sim time: its RViz configuration was not checked"]
        cases.append(("echo_standard_topics", echo_case(scenario, env, port, tmp, launch_file, limit, rviz_msgs)))
        cases.append(("rviz_shows_the_run", rviz_msgs))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    write_junit(result, "main_job", cases)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
