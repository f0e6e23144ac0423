#!/usr/bin/python3
"""Runs a command and writes a JUnit XML result with one test case: it passes when the command
exits 0 within the time limit (its output is the failure message otherwise).

usage: run_command_test.py NAME RESULT_XML TIME_LIMIT_S COMMAND [ARGS...]
"""
import os
import subprocess
import sys
from xml.sax.saxutils import escape


def main(argv):
    if len(argv) < 5:
        sys.stderr.write(__doc__)
        return 2
    name, result, limit, cmd = argv[1], argv[2], float(argv[3]), argv[4:]
    try:
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True,
                           timeout=limit, start_new_session=True)
        output, failure = p.stdout, (None if p.returncode == 0 else "exit code %d" % p.returncode)
    except subprocess.TimeoutExpired as e:
        output, failure = (e.stdout or b"").decode(errors="replace") if isinstance(e.stdout, bytes) else (e.stdout or ""), \
            "no exit within %g s" % limit
    print(output)
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             '<testsuite name="%s" tests="1" failures="%d" errors="0">' % (name, 1 if failure else 0),
             '  <testcase classname="%s" name="%s">' % (name, name)]
    if failure:
        lines.append('    <failure message="%s">%s</failure>' % (failure, escape(output[-20000:])))
    lines += ["  </testcase>", "</testsuite>"]
    os.makedirs(os.path.dirname(os.path.abspath(result)), exist_ok=True)
    with open(result, "w") as f:
        f.write("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
