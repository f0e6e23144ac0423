#!/usr/bin/python3
"""Sensor outputs do not depend on the host's load (issue 20, deliverable 4 and its acceptance).

The shortened reference scenario runs twice for DURATION s of sim time as fast as it can, the
second time beside two busy processes that load both cores; rosbag records lidar, radar,
camera, IMU and GPS topics in both. Checks, one test case each:
- recorded: each topic has messages in both runs from t <= 1 s on (the recorder was connected
  before the sensors started);
- identical: every message stamped up to DURATION - 0.5 s is in both runs, byte for byte
  (the header's seq aside, which counts per connection): the clock waits for the sensors
  (dynamics_node ~clock_followers), the sensors for /environment and for each rut instant's
  end-of-patches marker, so no weather change or rut reaches a different sweep under load.
- threads: a third run, idle, with sensors_node on one thread (~threads 1, in the generated
  launch file) gives the same messages as the first (all cores: the vehicles, the lidar's
  columns and the cameras' rows over threads), byte for byte.

usage: run_sensor_determinism.py SCENARIO LAUNCH_FILE RESULT_XML [DURATION_S] [WALL_LIMIT_S]
"""
import hashlib
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scripted_tests import free_port, stop_launch, write_junit  # noqa: E402

TOPICS = ["/fed_alpha/avt_341/points", "/tracer_x/avt_341/points", "/fed_alpha/radar/targets",
          "/fed_alpha/front/image_raw", "/fed_alpha/imu/data", "/m113/imu/data", "/m113/gps/fix"]


def wait_master(env, limit):
    deadline = time.time() + limit
    while time.time() < deadline:
        if subprocess.run(["rostopic", "list"], env=env, stdout=subprocess.DEVNULL,
                          stderr=subprocess.DEVNULL).returncode == 0:
            return True
        time.sleep(0.2)
    return False


def one_thread_launch(scenario, tmp, duration, name):
    """The scenario's generated launch file with sensors_node on one thread."""
    out = os.path.join(tmp, name + ".launch")
    subprocess.run(["rosrun", "avsp", "scenario_launch", scenario, "--duration", "%g" % duration,
                    "--real-time-factor", "0", "--output-dir", os.path.join(tmp, name + "_results"),
                    "--out", out], check=True, stdout=subprocess.DEVNULL)
    text = open(out).read()
    tag = '<node pkg="avsp_sensors" type="sensors_node"'
    start = text.index(tag)
    end = text.index(">", start) + 1
    text = text[:end] + '\n    <param name="threads" type="int" value="1"/>' + text[end:]
    open(out, "w").write(text)
    return out


def run(name, scenario, launch_file, tmp, duration, limit, hog, one_thread=False):
    """One run on its own master; returns (bag path, [problems])."""
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:%d" % port, ROS_IP="127.0.0.1")
    env.pop("ROS_HOSTNAME", None)
    bag = os.path.join(tmp, name + ".bag")
    log = open(os.path.join(tmp, name + ".log"), "w")
    core = subprocess.Popen(["roscore", "-p", str(port)], env=env, preexec_fn=os.setsid, stdout=log,
                            stderr=subprocess.STDOUT)
    hogs, recorder, launch = [], None, None
    try:
        if not wait_master(env, 30.0):
            return bag, ["%s: no ROS master on port %d" % (name, port)]
        recorder = subprocess.Popen(["rosbag", "record", "-O", bag] + TOPICS, env=env, preexec_fn=os.setsid,
                                    stdout=log, stderr=subprocess.STDOUT)
        time.sleep(2.0)  # the recorder registers its subscriptions before any publisher exists
        if hog:
            hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
        if one_thread:
            command = ["roslaunch", "-p", str(port), one_thread_launch(scenario, tmp, duration, name)]
        else:
            command = ["roslaunch", "-p", str(port), launch_file, "scenario:=" + scenario, "duration:=%g" % duration,
                       "real_time_factor:=0", "output_dir:=" + os.path.join(tmp, name + "_results")]
        launch = subprocess.Popen(command, env=env, preexec_fn=os.setsid, stdout=log, stderr=subprocess.STDOUT)
        start = time.time()
        try:
            rc = launch.wait(timeout=limit)
        except subprocess.TimeoutExpired:
            return bag, ["%s: the run did not end within %g s (wall)" % (name, limit)]
        print("run_sensor_determinism: %s run (%s%s) ended with %d after %.1f s wall"
              % (name, "two busy processes" if hog else "idle", ", sensors_node on one thread" if one_thread else "",
                 rc, time.time() - start))
        return bag, ([] if rc == 0 else ["%s: roslaunch exited with %d (log %s)" % (name, rc, log.name)])
    finally:
        for h in hogs:
            h.kill()
            h.wait()
        if launch is not None:
            stop_launch(launch)
        if recorder is not None:
            stop_launch(recorder)  # SIGINT: rosbag closes the bag
        stop_launch(core)
        log.close()


def messages(bag_path):
    """{topic: {stamp (secs, nsecs): md5 of the message without its header seq}}."""
    import rosbag
    out = {t: {} for t in TOPICS}
    active = bag_path + ".active"
    path = bag_path if os.path.exists(bag_path) else active
    with rosbag.Bag(path) as bag:
        for topic, raw, _t in bag.read_messages(raw=True):
            data = raw[1]
            _seq, secs, nsecs = struct.unpack("<III", data[:12])
            out[topic][(secs, nsecs)] = hashlib.md5(data[4:]).hexdigest()
    return out


def compare(a, b, window, names):
    """(problems with what was recorded, differences, messages compared) between two runs."""
    recorded, identical = [], []
    total = 0
    for topic in TOPICS:
        ka = {k for k in a[topic] if k[0] + 1e-9 * k[1] <= window}
        kb = {k for k in b[topic] if k[0] + 1e-9 * k[1] <= window}
        if not ka or not kb:
            recorded.append("%s: no message (%s %d, %s %d)" % (topic, names[0], len(ka), names[1], len(kb)))
            continue
        first = max(min(ka), min(kb))
        if first[0] + 1e-9 * first[1] > 1.0:
            recorded.append("%s: first message in both runs only at %.3f s" % (topic, first[0] + 1e-9 * first[1]))
        ka = {k for k in ka if k >= first}
        kb = {k for k in kb if k >= first}
        if ka != kb:
            identical.append("%s: %d stamps only in the %s run, %d only in the %s one"
                             % (topic, len(ka - kb), names[0], len(kb - ka), names[1]))
        differ = sorted(k for k in ka & kb if a[topic][k] != b[topic][k])
        if differ:
            identical.append("%s: %d of %d messages differ, the first stamped %.3f s"
                             % (topic, len(differ), len(ka & kb), differ[0][0] + 1e-9 * differ[0][1]))
        total += len(ka & kb)
        print("run_sensor_determinism: %s / %s %-28s %5d messages in both runs from %.3f s, %d differ"
              % (names[0], names[1], topic, len(ka & kb), first[0] + 1e-9 * first[1], len(differ)))
    print("run_sensor_determinism: %s / %s: %d messages compared" % (names[0], names[1], total))
    return recorded, identical


def main(argv):
    if len(argv) < 4:
        sys.stderr.write(__doc__)
        return 2
    scenario, launch_file, result = argv[1], argv[2], argv[3]
    duration = float(argv[4]) if len(argv) > 4 else 6.0
    limit = float(argv[5]) if len(argv) > 5 else 240.0
    tmp = tempfile.mkdtemp(prefix="avsp_sensor_determinism_")
    cases = []
    try:
        bag_a, problems_a = run("idle", scenario, launch_file, tmp, duration, limit, False)
        bag_b, problems_b = run("loaded", scenario, launch_file, tmp, duration, limit, True)
        bag_c, problems_c = run("one_thread", scenario, launch_file, tmp, duration, limit, False, one_thread=True)
        if problems_a or problems_b or problems_c:
            cases += [("recorded", problems_a + problems_b + problems_c),
                      ("identical", ["no comparison: a run failed"]), ("threads", ["no comparison: a run failed"])]
            return write_junit(result, "sensor_determinism", cases)
        a, b, c = messages(bag_a), messages(bag_b), messages(bag_c)
        window = duration - 0.5
        recorded, identical = compare(a, b, window, ("idle", "loaded"))
        recorded_c, threads = compare(a, c, window, ("idle", "one_thread"))
        cases += [("recorded", recorded + recorded_c), ("identical", identical), ("threads", threads)]
        return write_junit(result, "sensor_determinism", cases)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
