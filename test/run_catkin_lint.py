#!/usr/bin/python3
"""Runs catkin_lint over every package of the repository and writes a JUnit XML result with
one test case per package: a package passes when catkin_lint reports nothing about it
(errors, warnings or notices at -W2).

usage: run_catkin_lint.py REPOSITORY_ROOT RESULT_XML
"""
import os
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from xml.sax.saxutils import escape

PACKAGES = ["avsp", "avsp_msgs", "avsp_terrain", "avsp_dynamics", "avsp_sensors"]
# catkin_lint stops descending at the root package.xml, so each package path is named.
PATHS = [".", "avsp_msgs", "avsp_terrain", "avsp_dynamics", "avsp_sensors"]
# The sources are linted in a copy named 'avsp' (the root package's name) without the
# colcon build/install/log folders and the main job's results/, whose files catkin_lint would
# take for sources; only at the top level (src/results/ is a source folder).
TOP_LEVEL_SKIP = {".git", "build", "install", "log", "results"}


def skip(directory, names):
    ignored = {n for n in names if n == "__pycache__"}
    if os.path.abspath(directory) == skip.root:
        ignored |= TOP_LEVEL_SKIP & set(names)
    return ignored


def main(argv):
    if len(argv) != 3:
        sys.stderr.write(__doc__)
        return 2
    source, result = argv[1], argv[2]
    env = dict(os.environ, PATH="/usr/bin:/bin:" + os.environ.get("PATH", ""))
    with tempfile.TemporaryDirectory(prefix="avsp_catkin_lint_") as tmp:
        root = os.path.join(tmp, "avsp")
        skip.root = os.path.abspath(source)
        shutil.copytree(source, root, ignore=skip, symlinks=True)
        proc = subprocess.run(["catkin_lint", "-W2", "--strict", "--quiet", "--color", "never", "--offline"] +
                              [os.path.join(root, p) for p in PATHS],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True, env=env)
    lines = [l for l in proc.stdout.splitlines() if l.strip()]
    print(proc.stdout)
    cases = []
    failures = 0
    for pkg in PACKAGES:
        mine = [l for l in lines if l.startswith(pkg + ":")]
        cases.append((pkg, mine))
        failures += 1 if mine else 0
    # Output that names no package (catkin_lint itself failing) fails the run too.
    orphan = [l for l in lines if not any(l.startswith(p + ":") for p in PACKAGES)]
    if proc.returncode != 0 and not any(m for _p, m in cases):
        orphan.append("catkin_lint exited with %d" % proc.returncode)
    if orphan:
        cases.append(("catkin_lint_run", orphan))
        failures += 1
    else:
        cases.append(("catkin_lint_run", []))
    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           '<testsuite name="catkin_lint" tests="%d" failures="%d" errors="0">' % (len(cases), failures)]
    for name, msgs in cases:
        out.append('  <testcase classname="catkin_lint" name="%s">' % name)
        if msgs:
            out.append('    <failure message="%d finding(s)">%s</failure>' % (len(msgs), escape("\n".join(msgs))))
        out.append("  </testcase>")
    out.append("</testsuite>")
    os.makedirs(os.path.dirname(os.path.abspath(result)), exist_ok=True)
    with open(result, "w") as f:
        f.write("\n".join(out) + "\n")
    ET.parse(result)  # what we wrote must be valid XML
    return 0 if failures == 0 else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
