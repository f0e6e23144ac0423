#!/usr/bin/python3
"""Counts test cases in the gtest/rostest/JUnit XML files colcon's test run left under a
build directory and prints 'N passed, N failed' as the last line.

Exit status: 0 when at least one test ran and none failed, 1 otherwise.

rostest writes two files per test: the gtest node's own cases (rosunit-<name>.xml), which
are counted, and rostest's one-case wrapper (rostest-*.xml, case 'test<name>'), which is
counted only as a failure when it failed and its rosunit file shows no failure (the node
crashed or never wrote results). CTest's Test.xml lives outside test_results/.
"""
import os
import sys
import xml.etree.ElementTree as ET


def result_files(build_dir):
    for root, _dirs, files in os.walk(build_dir):
        if os.sep + "test_results" not in root + os.sep and not root.endswith("test_results"):
            continue
        for name in sorted(files):
            if name.endswith(".xml"):
                yield os.path.join(root, name)


def read_cases(path):
    """Returns [(label, outcome)] for one JUnit-style file, outcome in pass/fail/skip. An
    unreadable file, or one with no test case (the binary did not run its tests), is one
    failing case."""
    try:
        cases = list(ET.parse(path).getroot().iter("testcase"))
    except ET.ParseError as err:
        return [("unreadable result file (%s)" % err, "fail")]
    if not cases:
        return [("no test case in result file", "fail")]
    out = []
    for case in cases:
        label = "%s.%s" % (case.get("classname", "?"), case.get("name", "?"))
        if case.find("failure") is not None or case.find("error") is not None:
            out.append((label, "fail"))
        elif case.find("skipped") is not None or case.get("status") == "notrun":
            out.append((label, "skip"))
        else:
            out.append((label, "pass"))
    return out


def wrapper_misses(path, cases):
    """rostest wrapper cases that failed while the node's own rosunit-<name>.xml shows no
    failure (the node crashed or wrote nothing): the only wrapper cases that count."""
    missed = []
    for label, outcome in cases:
        if outcome != "fail":
            continue
        name = label.rsplit(".", 1)[-1]
        inner = os.path.join(os.path.dirname(path), "rosunit-%s.xml" % name[len("test"):])
        if not os.path.exists(inner) or all(o != "fail" for _l, o in read_cases(inner)):
            missed.append((label, outcome))
    return missed


def main():
    build_dir = sys.argv[1] if len(sys.argv) > 1 else "build"
    totals = {"pass": 0, "fail": 0, "skip": 0}
    failed_names = []
    for path in result_files(build_dir):
        cases = read_cases(path)
        if os.path.basename(path).startswith("rostest-"):
            cases = wrapper_misses(path, cases)
        counts = {o: sum(1 for _l, c in cases if c == o) for o in totals}
        print("  %-60s %3d passed %3d failed %3d skipped"
              % (os.path.relpath(path, build_dir), counts["pass"], counts["fail"], counts["skip"]))
        for o in totals:
            totals[o] += counts[o]
        failed_names += ["%s (%s)" % (l, os.path.basename(path)) for l, o in cases if o == "fail"]
    for name in failed_names:
        print("FAILED: " + name)
    if totals["pass"] + totals["fail"] == 0:
        print("no test was executed (no result files under %s)" % build_dir)
        totals["fail"] = 1
    line = "%d passed, %d failed" % (totals["pass"], totals["fail"])
    if totals["skip"]:
        line += ", %d skipped" % totals["skip"]
    print(line)
    return 0 if totals["fail"] == 0 and totals["pass"] > 0 else 1


if __name__ == "__main__":
    sys.exit(main())
