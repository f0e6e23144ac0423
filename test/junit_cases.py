"""The JUnit XML result of the scripted tests (run_main_job.py, run_fault_injection.py): one
test case per (name, failure messages) pair, passed when the list is empty."""
import os
from xml.sax.saxutils import escape


def write_junit(result, suite, cases):
    """Writes `cases` [(name, [messages])] as test suite `suite` to `result` and prints a line per case."""
    failures = sum(1 for _n, m in cases if m)
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             '<testsuite name="%s" tests="%d" failures="%d" errors="0">' % (suite, len(cases), failures)]
    for n, msgs in cases:
        lines.append('  <testcase classname="%s" name="%s">' % (suite, n))
        if msgs:
            lines.append('    <failure message="%s">%s</failure>' % (escape(msgs[0][:200], {'"': "&quot;"}),
                                                                    escape("\n".join(msgs))))
        lines.append("  </testcase>")
    lines.append("</testsuite>")
    os.makedirs(os.path.dirname(os.path.abspath(result)), exist_ok=True)
    with open(result, "w") as f:
        f.write("\n".join(lines) + "\n")
    for n, msgs in cases:
        print("%s: %s" % (n, "FAILED: " + "; ".join(msgs) if msgs else "ok"))
