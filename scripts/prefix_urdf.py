#!/usr/bin/env python3
"""Prints a URDF with every link name prefixed by '<vehicle>/', so that one robot
description can serve several vehicles of the same model and TF frames read
'<vehicle>/base_link' (docs/ARCHITECTURE.md: prefixed names, no tf_prefix).

usage: python3 prefix_urdf.py URDF_FILE VEHICLE_NAME
"""
import os
import re
import sys
import xml.etree.ElementTree as ET

NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def main(argv):
    if len(argv) != 3:
        sys.stderr.write(__doc__)
        return 2
    path, vehicle = argv[1], argv[2]
    if not NAME.match(vehicle):
        sys.stderr.write("prefix_urdf: vehicle name '%s' must be a ROS name (letters, digits, _)\n" % vehicle)
        return 2
    if not os.path.isfile(path):
        # avt_341.launch model:=<m> reads urdf/<m>.urdf: an unknown model, said in one line.
        folder = os.path.dirname(os.path.abspath(path))
        known = sorted(f[:-5] for f in os.listdir(folder) if f.endswith(".urdf")) if os.path.isdir(folder) else []
        model = os.path.basename(path)[:-5] if path.endswith(".urdf") else os.path.basename(path)
        sys.stderr.write("prefix_urdf: unknown model '%s' (no %s); known models: %s\n"
                         % (model, path, ", ".join(known) if known else "none in " + folder))
        return 1
    try:
        tree = ET.parse(path)
    except (OSError, ET.ParseError) as err:
        sys.stderr.write("prefix_urdf: %s: %s\n" % (path, err))
        return 1
    robot = tree.getroot()
    if robot.tag != "robot":
        sys.stderr.write("prefix_urdf: %s: root element is <%s>, not <robot>\n" % (path, robot.tag))
        return 1
    links = {link.get("name") for link in robot.findall("link")}
    for link in robot.findall("link"):
        link.set("name", vehicle + "/" + link.get("name"))
    for joint in robot.findall("joint"):
        for tag in ("parent", "child"):
            element = joint.find(tag)
            if element is None or element.get("link") not in links:
                sys.stderr.write("prefix_urdf: %s: joint '%s' has no valid <%s link>\n" % (path, joint.get("name"), tag))
                return 1
            element.set("link", vehicle + "/" + element.get("link"))
    robot.set("name", vehicle)
    sys.stdout.write(ET.tostring(robot, encoding="unicode"))
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
