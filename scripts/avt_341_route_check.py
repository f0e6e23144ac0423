#!/usr/bin/python3
"""The launch-prefix of the AVT-341 stack's global path node (launch/avt_341_stack.launch):
checks the route against the stack's occupancy grid, then runs the node. The stack's path node
crashes on a waypoint outside its grid (it indexes the grid with it); this stops the launch
first, naming the waypoint, the grid and the fix.

usage: avt_341_route_check.py --grid-llx M --grid-lly M --grid-size M --waypoints-x YAML
                              --waypoints-y YAML -- COMMAND [ARGS...]
Exit 1 (and the command does not run) for a route that is not two equal, non-empty lists of
finite numbers, or that leaves the grid [llx, llx + size) x [lly, lly + size).
"""
import math
import os
import sys

import yaml


def fail(text):
    sys.stderr.write("avt_341_route_check: %s\n" % text)
    return 1


def main(argv):
    if "--" not in argv:
        sys.stderr.write(__doc__)
        return 2
    split = argv.index("--")
    options, command = argv[1:split], argv[split + 1:]
    if len(options) % 2 or not command:
        sys.stderr.write(__doc__)
        return 2
    values = dict(zip(options[0::2], options[1::2]))
    known = {"--grid-llx", "--grid-lly", "--grid-size", "--waypoints-x", "--waypoints-y"}
    if set(values) != known:
        return fail("options %s are required, got %s" % (sorted(known), sorted(values)))
    try:
        llx, lly, size = (float(values[k]) for k in ("--grid-llx", "--grid-lly", "--grid-size"))
    except ValueError as e:
        return fail("grid: %s" % e)
    if not all(math.isfinite(v) for v in (llx, lly, size)) or size <= 0:
        return fail("grid: llx, lly must be finite and grid_size > 0 (got %g, %g, %g)" % (llx, lly, size))
    route = []
    for key in ("--waypoints-x", "--waypoints-y"):
        try:
            v = yaml.safe_load(values[key])
        except yaml.YAMLError as e:
            return fail("%s: not YAML: %s" % (key[2:].replace("-", "_"), e))
        if not isinstance(v, list) or not v or not all(
                isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for c in v):
            return fail("%s must be a non-empty YAML list of finite numbers (m), got %r" %
                        (key[2:].replace("-", "_"), values[key]))
        route.append(v)
    if len(route[0]) != len(route[1]):
        return fail("waypoints_x has %d entries, waypoints_y %d: they must pair up" % (len(route[0]), len(route[1])))
    for k, (x, y) in enumerate(zip(*route)):
        if not (llx <= x < llx + size and lly <= y < lly + size):
            return fail("waypoint %d (%g, %g) lies outside the stack's grid x [%g, %g) y [%g, %g) m: its global "
                        "path node would crash. Move the waypoint, or enlarge grid_size (the grid is centred on "
                        "the start)." % (k, x, y, llx, llx + size, lly, lly + size))
    os.execvp(command[0], command)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
