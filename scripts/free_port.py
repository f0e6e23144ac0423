#!/usr/bin/python3
"""Prints a TCP port for a private ROS master that nothing is bound to now, below Linux's
ephemeral range (32768-60999, which any outgoing connection may hold); exits 1 if none of 200
tries in 20000-32000 is free. Used by run_team_check.sh, run_demo.sh and rviz_screenshot.sh."""
import random
import socket
import sys

for _ in range(200):
    port = random.randint(20000, 32000)
    with socket.socket() as s:
        try:
            s.bind(("0.0.0.0", port))
        except OSError:
            continue
    print(port)
    sys.exit(0)
sys.stderr.write("free_port.py: no free TCP port in 20000-32000\n")
sys.exit(1)
