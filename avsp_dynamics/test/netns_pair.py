"""Two network namespaces joined by a veth pair, each with its own address: two "hosts" on one
machine for the two-host test (two_hosts.py) and the partitions benchmark
(bench/bench_partitions.py). Needs root (iproute2, util-linux nsenter)."""
import subprocess


def inside(ns):
    """The command prefix that runs a command in network namespace `ns`. Enters only the network
    namespace: `ip netns exec` also remounts / as a slave mount, which fails where / is not a
    mount point (a chroot)."""
    return ["nsenter", "--net=/run/netns/" + ns]


def create(ns_a, ns_b, veth_a, veth_b, ip_a, ip_b):
    """Creates both namespaces and the link (/24 addresses, links and loopbacks up). Returns None,
    or the failing command and its output (what exists then is for delete() to remove)."""
    for cmd in (["ip", "netns", "add", ns_a], ["ip", "netns", "add", ns_b],
                ["ip", "link", "add", veth_a, "type", "veth", "peer", "name", veth_b],
                ["ip", "link", "set", veth_a, "netns", ns_a], ["ip", "link", "set", veth_b, "netns", ns_b],
                inside(ns_a) + ["ip", "addr", "add", ip_a + "/24", "dev", veth_a],
                inside(ns_b) + ["ip", "addr", "add", ip_b + "/24", "dev", veth_b],
                inside(ns_a) + ["ip", "link", "set", veth_a, "up"],
                inside(ns_b) + ["ip", "link", "set", veth_b, "up"],
                inside(ns_a) + ["ip", "link", "set", "lo", "up"],
                inside(ns_b) + ["ip", "link", "set", "lo", "up"]):
        r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
        if r.returncode != 0:
            return "%s: %s" % (" ".join(cmd), r.stdout)
    return None


def delete(*namespaces):
    """Removes the namespaces (and with them the veth pair); silent about ones that do not exist."""
    for ns in namespaces:
        subprocess.run(["ip", "netns", "del", ns], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
