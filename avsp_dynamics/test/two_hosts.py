#!/usr/bin/python3
"""Two hosts for real (issue 7): the partitioned run of partitions.test with partition p2 on a
second host. Two network namespaces joined by a veth pair, each with its own IP address, stand
in for the hosts: host A (10.231.<k>.1) runs the ROS master, lockstep_clock, partitions "one"
and "p1" and the test node (test_partitions, suite Partitions); host B (10.231.<k>.2) runs
partition "p2" with ROS_IP set, talking to the master and to the other nodes over the veth
link only. The test node checks that the four vehicles' odometry is bit-identical between the
one-partition layout and the layout split across the hosts. Needs root (network namespaces).
The namespaces are removed on every exit path.

usage: two_hosts.py DEVEL_SETUP TEST_BINARY RESULT_XML [UNTIL_S]
"""
import os
import signal
import subprocess
import sys
import time
from xml.sax.saxutils import escape

from netns_pair import create, delete, inside


def write_failure(result, message):
    os.makedirs(os.path.dirname(os.path.abspath(result)), exist_ok=True)
    with open(result, "w") as f:
        f.write('<?xml version="1.0" encoding="UTF-8"?>\n'
                '<testsuite name="two_hosts" tests="1" failures="1" errors="0">\n'
                '  <testcase classname="TwoHosts" name="PartitionOnASecondHostGivesIdenticalOdometry">\n'
                '    <failure message="%s">%s</failure>\n  </testcase>\n</testsuite>\n'
                % (escape(message.splitlines()[0] if message else "failed", {'"': "&quot;"}),
                   escape(message[-20000:])))


def run(cmd):
    return subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)


def main(argv):
    if len(argv) < 4:
        sys.stderr.write(__doc__)
        return 2
    setup, binary, result = argv[1], argv[2], argv[3]
    until = argv[4] if len(argv) > 4 else "10.0"
    if os.geteuid() != 0:
        write_failure(result, "two_hosts.py needs root to create network namespaces (run the tests as root)")
        return 0
    k = os.getpid() % 200 + 20
    ns_a, ns_b = "avsp_a%d" % os.getpid(), "avsp_b%d" % os.getpid()
    veth_a, veth_b = "avspa%d" % (os.getpid() % 100000), "avspb%d" % (os.getpid() % 100000)
    ip_a, ip_b = "10.231.%d.1" % k, "10.231.%d.2" % k
    port = 11400 + k
    master = "http://%s:%d" % (ip_a, port)
    procs = []
    log = []
    try:
        failed = create(ns_a, ns_b, veth_a, veth_b, ip_a, ip_b)
        if failed:
            write_failure(result, "network set-up failed: " + failed)
            return 0
        def on_host(ns, ip, script, name):
            env = {"HOME": os.environ.get("HOME", "/root"), "PATH": "/usr/bin:/bin:/usr/sbin:/sbin",
                   "ROS_IP": ip, "ROS_MASTER_URI": master, "ROS_HOME": "/tmp/avsp_two_hosts_%s" % name}
            out = open("/tmp/avsp_two_hosts_%d_%s.log" % (os.getpid(), name), "w")
            p = subprocess.Popen(inside(ns) + ["bash", "-c", ". %s && %s" % (setup, script)],
                                 env=env, stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
            procs.append((name, p, out.name))
            return p

        on_host(ns_a, ip_a, "exec roscore -p %d" % port, "master")
        time.sleep(1.0)
        deadline = time.time() + 30.0
        while time.time() < deadline:
            r = subprocess.run(inside(ns_a) + ["bash", "-c",
                                ". %s && ROS_MASTER_URI=%s rosparam list >/dev/null 2>&1" % (setup, master)])
            if r.returncode == 0:
                break
            time.sleep(0.5)
        on_host(ns_a, ip_a, "exec roslaunch --wait avsp_dynamics partitions_nodes.launch host_a:=true host_b:=false",
                "host_a")
        on_host(ns_b, ip_b, "exec roslaunch --wait avsp_dynamics partitions_nodes.launch host_a:=false host_b:=true",
                "host_b")
        # The test node on host A: every vehicle's lockstep controller, comparing the layouts.
        test = subprocess.run(
            inside(ns_a) + ["bash", "-c",
             ". %s && rosparam set /test_partitions/vehicles '[m113, mrzr, tracer_x, fed_alpha]' && "
             "rosparam set /test_partitions/until %s && rosparam set /test_partitions/crossing fed_alpha && "
             "rosparam set /test_partitions/crossed mrzr && exec %s __name:=test_partitions "
             "--gtest_filter=Partitions.* --gtest_output=xml:%s" % (setup, until, binary, result)],
            env={"HOME": os.environ.get("HOME", "/root"), "PATH": "/usr/bin:/bin:/usr/sbin:/sbin", "ROS_IP": ip_a,
                 "ROS_MASTER_URI": master, "ROS_HOME": "/tmp/avsp_two_hosts_test"},
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True, timeout=300)
        # Partition p2 really ran on host B: the master lists it at host B's address.
        where = run(inside(ns_a) + ["bash", "-c",
                     ". %s && ROS_MASTER_URI=%s rosnode list --all 2>&1 | grep dynamics"
                     % (setup, master)])
        log.append("dynamics partitions on the master (URI, name):\n" + where.stdout)
        print("\n".join(log))
        print(test.stdout)
        if not any(line.startswith("http://%s:" % ip_b) and line.endswith("/two/dynamics_p2")
                   for line in where.stdout.splitlines()):
            write_failure(result, "partition p2 is not registered at host B's address %s:\n%s\n%s"
                          % (ip_b, where.stdout, test.stdout))
            return 0
        for name, p, path in procs:
            if name.startswith("host"):
                with open(path) as f:
                    text = f.read()
                print("--- %s log:\n%s" % (name, text[-3000:]))
        if test.returncode != 0 and not os.path.exists(result):
            write_failure(result, "test_partitions exited %d:\n%s" % (test.returncode, test.stdout))
        return 0
    except Exception as e:  # noqa: BLE001 - any failure must become a failing result, not a hang
        write_failure(result, "two_hosts.py: %r\n%s" % (e, "\n".join(log)))
        return 0
    finally:
        for name, p, path in reversed(procs):
            if p.poll() is None:
                try:
                    os.killpg(p.pid, signal.SIGINT)
                    p.wait(timeout=15)
                except Exception:  # noqa: BLE001
                    try:
                        os.killpg(p.pid, signal.SIGKILL)
                    except ProcessLookupError:
                        pass
            try:
                os.remove(path)
            except OSError:
                pass
        delete(ns_a, ns_b)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
