#!/usr/bin/python3
"""Every standard message type an AVSP node publishes can be decoded in Python, as
`rostopic echo`, rosbag and the scripted tests do (issue 23, item 7: a machine set up by
`make demo` once answered `rostopic echo /ego/avt_341/odometry` with "Cannot load message class
for [nav_msgs/Odometry]", python3-nav-msgs not being installed).

The types are those of every `advertise<pkg::Type>` in the C++ sources, plus those published
through libraries (tf2_ros' broadcasters: tf2_msgs/TFMessage; image_transport:
sensor_msgs/Image; roscpp's log: rosgraph_msgs/Log). For each type outside avsp_msgs (built
in the workspace) the check asks that
- tools/debian-packages.txt installs its Debian Python package (python3-<pkg with - for _>),
  so that a fresh set-up has it, and
- roslib.message.get_message_class() loads its class here (what rostopic echo calls).
run_main_job.py's echo_standard_topics runs `rostopic echo -n1` on the topics themselves.

usage: check_message_classes.py REPOSITORY_ROOT
"""
import os
import re
import sys

ADVERTISE = re.compile(r"advertise<\s*([a-z0-9_]+)::([A-Za-z0-9_]+)\s*>")
THROUGH_LIBRARIES = {"tf2_msgs/TFMessage": "tf2_ros::TransformBroadcaster, StaticTransformBroadcaster",
                     "sensor_msgs/Image": "image_transport::Publisher",
                     "rosgraph_msgs/Log": "roscpp's /rosout",
                     "diagnostic_msgs/DiagnosticArray": "diagnostic_updater::Updater's /diagnostics"}
SOURCE_DIRS = ["src", "include", "avsp_dynamics", "avsp_sensors", "avsp_terrain"]


def advertised_types(root):
    found = {}
    for top in SOURCE_DIRS:
        for folder, _dirs, files in os.walk(os.path.join(root, top)):
            for name in files:
                if not name.endswith((".cpp", ".hpp")) or "/test" in folder[len(root):]:
                    continue
                path = os.path.join(folder, name)
                with open(path, encoding="utf-8") as f:
                    for pkg, msg in ADVERTISE.findall(f.read()):
                        found.setdefault(pkg + "/" + msg, os.path.relpath(path, root))
    return found


def main(argv):
    if len(argv) != 2:
        sys.stderr.write(__doc__)
        return 2
    root = argv[1]
    types = advertised_types(root)
    if "nav_msgs/Odometry" not in types:  # the scan itself must work
        print("FAILED: no advertise<nav_msgs::Odometry> found under %s: the source scan is broken" % root)
        return 1
    types.update(THROUGH_LIBRARIES)
    with open(os.path.join(root, "tools", "debian-packages.txt")) as f:
        listed = {line.split("#")[0].strip() for line in f}
    import roslib.message
    failed = 0
    for t in sorted(types):
        pkg = t.split("/")[0]
        if pkg == "avsp_msgs":
            continue
        debian = "python3-" + pkg.replace("_", "-")
        problems = []
        if debian not in listed:
            problems.append("%s is not in tools/debian-packages.txt" % debian)
        try:
            if roslib.message.get_message_class(t) is None:
                problems.append("roslib.message.get_message_class('%s') found no class" % t)
        except Exception as e:  # noqa: BLE001 - any failure to load is the finding
            problems.append("loading the class failed: %s" % e)
        failed += 1 if problems else 0
        print("%s: %s (published by %s)" % ("FAILED" if problems else "ok", t, types[t]) +
              "".join("\n  " + p for p in problems))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
