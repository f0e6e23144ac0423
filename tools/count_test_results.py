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


def count_file(path):
    """Returns (passed, failed, skipped, failed_names) for one JUnit-style file."""
    try:
        tree = ET.parse(path)
    except ET.ParseError as err:
        return 0, 1, 0, ["%s: unreadable result file (%s)" % (path, err)]
    passed = failed = skipped = 0
    names = []
    cases = list(tree.getroot().iter("testcase"))
    if not cases:
        # A result file with no test case means the test binary did not run its tests.
        return 0, 1, 0, ["%s: no test case in result file" % path]
    for case in cases:
        label = "%s.%s" % (case.get("classname", "?"), case.get("name", "?"))
        if case.find("failure") is not None or case.find("error") is not None:
            failed += 1
            names.append("%s (%s)" % (label, os.path.basename(path)))
        elif case.find("skipped") is not None or case.get("status") == "notrun":
            skipped += 1
        else:
            passed += 1
    return passed, failed, skipped, names


def main():
    build_dir = sys.argv[1] if len(sys.argv) > 1 else "build"
    total_passed = total_failed = total_skipped = 0
    failed_names = []
    files = list(result_files(build_dir))
    for path in files:
        p, f, s, names = count_file(path)
        if os.path.basename(path).startswith("rostest-"):
            # Wrapper: one case per test node; only a failure the node's own file lacks counts.
            wrapper_cases = list(ET.parse(path).getroot().iter("testcase")) if f == 0 or names else []
            missed = 0
            for case in wrapper_cases:
                if case.find("failure") is None and case.find("error") is None:
                    continue
                inner = os.path.join(os.path.dirname(path), "rosunit-%s.xml" % case.get("name", "")[len("test"):])
                if not os.path.exists(inner) or count_file(inner)[1] == 0:
                    missed += 1
            if f and not wrapper_cases:
                missed = f  # unreadable wrapper
            p, f, s = 0, missed, 0
            names = names if missed else []
        print("  %-60s %3d passed %3d failed %3d skipped" % (os.path.relpath(path, build_dir), p, f, s))
        total_passed += p
        total_failed += f
        total_skipped += s
        failed_names.extend(names)
    for name in failed_names:
        print("FAILED: " + name)
    if total_passed + total_failed == 0:
        print("no test was executed (no result files under %s)" % build_dir)
        total_failed = max(total_failed, 1)
    line = "%d passed, %d failed" % (total_passed, total_failed)
    if total_skipped:
        line += ", %d skipped" % total_skipped
    print(line)
    return 0 if total_failed == 0 and total_passed > 0 else 1


if __name__ == "__main__":
    sys.exit(main())
