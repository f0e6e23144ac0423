# ROS 1 has no authentication: any host that reaches a node's ports can publish to it, or
# shut it down over XML-RPC. Unless the user names an address (ROS_IP or ROS_HOSTNAME), AVSP's
# nodes advertise loopback and bind their TCPROS servers to it (README, "Network exposure").
if [ -z "${ROS_IP:-}" ] && [ -z "${ROS_HOSTNAME:-}" ]; then
  export ROS_IP=127.0.0.1
fi
