#!/bin/bash
# launch-prefix for a node that must start late (a peer partition connecting after the others
# began): waits 3 s, then runs the node.
sleep 3
exec "$@"
