// run_recorder's watch over the run (run_supervisor.hpp).
#include "avsp/ros/run_supervisor.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <optional>

#include <ros/master.h>
#include <ros/network.h>
#include <xmlrpcpp/XmlRpcClient.h>

namespace avsp
{
namespace node
{
namespace
{
/// Connects to host:port within `timeout_ms`; "" on success, else why not.
std::string tryConnect(const std::string& host, std::uint32_t port, int timeout_ms)
{
  addrinfo hints{};
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  if (getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &found) != 0 || found == nullptr)
    return "cannot resolve host '" + host + "'";
  std::string why = "no address";
  for (addrinfo* a = found; a != nullptr; a = a->ai_next)
  {
    const int fd = socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0)
      continue;
    int rc = connect(fd, a->ai_addr, a->ai_addrlen);
    if (rc != 0 && errno == EINPROGRESS)
    {
      pollfd p{ fd, POLLOUT, 0 };
      const int ready = ::poll(&p, 1, timeout_ms);
      int err = ready == 0 ? ETIMEDOUT : errno;
      if (ready == 1)
      {
        socklen_t len = sizeof err;
        getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len);
      }
      rc = ready == 1 && err == 0 ? 0 : -1;
      errno = err;
    }
    why = rc == 0 ? "" : std::string(std::strerror(errno));
    ::close(fd);
    if (rc == 0)
      break;
  }
  freeaddrinfo(found);
  return why.empty() ? "" : "XML-RPC port " + host + ":" + std::to_string(port) + ": " + why;
}

/// Calls `method` on the XML-RPC server at `uri`; false if it did not answer [1, msg, value].
bool callServer(const std::string& uri, const char* method, const XmlRpc::XmlRpcValue& params,
                XmlRpc::XmlRpcValue& value)
{
  std::string host;
  std::uint32_t port = 0;
  if (!ros::network::splitURI(uri, host, port))
    return false;
  XmlRpc::XmlRpcClient client(host.c_str(), static_cast<int>(port), "/");
  XmlRpc::XmlRpcValue result;
  const bool ok = client.execute(method, params, result) && !client.isFault() &&
                  result.getType() == XmlRpc::XmlRpcValue::TypeArray && result.size() == 3 &&
                  result[0].getType() == XmlRpc::XmlRpcValue::TypeInt && static_cast<int>(result[0]) == 1;
  client.close();
  if (ok)
    value = result[2];
  return ok;
}
}  // namespace

RunSupervisor::RunSupervisor(ros::NodeHandle& nh, std::vector<std::string> watched) : watch_(std::move(watched))
{
  log_sub_ = nh.subscribe("/rosout", 1000, &RunSupervisor::onLog, this);
}

void RunSupervisor::onLog(const rosgraph_msgs::Log::ConstPtr& m)
{
  if (m->level >= rosgraph_msgs::Log::ERROR)
    watch_.noteError(m->name, m->msg, m->level >= rosgraph_msgs::Log::FATAL, ros::Time::now().toSec());
}

void RunSupervisor::poll(double sim_time)
{
  pollLaunchServers(sim_time);
  pingWatched(sim_time);
  watch_.noteTime(sim_time, ros::WallTime::now().toSec());
}

void RunSupervisor::pollLaunchServers(double sim_time)
{
  XmlRpc::XmlRpcValue servers;
  if (!ros::param::getCached("/roslaunch/uris", servers) || servers.getType() != XmlRpc::XmlRpcValue::TypeStruct)
    return;
  for (auto it = servers.begin(); it != servers.end(); ++it)
  {
    if (it->second.getType() != XmlRpc::XmlRpcValue::TypeString)
      continue;
    const std::string uri = it->second;
    XmlRpc::XmlRpcValue lists;
    // [[active (name, spawns)...], [dead (name, spawns)...]]; a server that is gone is skipped
    // (it was a launch that ended, or the run is shutting down).
    if (!callServer(uri, "list_processes", XmlRpc::XmlRpcValue(), lists) ||
        lists.getType() != XmlRpc::XmlRpcValue::TypeArray || lists.size() != 2 ||
        lists[1].getType() != XmlRpc::XmlRpcValue::TypeArray)
      continue;
    for (int k = 0; k < lists[1].size(); ++k)
    {
      XmlRpc::XmlRpcValue& entry = lists[1][k];
      if (entry.getType() != XmlRpc::XmlRpcValue::TypeArray || entry.size() < 1 ||
          entry[0].getType() != XmlRpc::XmlRpcValue::TypeString)
        continue;
      const std::string process = entry[0];
      if (!dead_seen_.insert(uri + " " + process).second)
        continue;
      // roslaunch answers process_info for live processes only: a dead one's exit code is unknown.
      watch_.noteProcessDied(process, std::nullopt, sim_time, ros::WallTime::now().toSec());
    }
  }
}

void RunSupervisor::pingWatched(double sim_time)
{
  for (const std::string& node : watch_.watched())
  {
    // The master is asked once per node, not every poll; again only after a failed connect
    // (a node that restarted registers a new URI).
    auto known = uris_.find(node);
    if (known == uris_.end())
    {
      XmlRpc::XmlRpcValue request, response, payload;
      request[0] = ros::this_node::getName();
      request[1] = node;
      if (!ros::master::execute("lookupNode", request, response, payload, false))
      {
        watch_.notePing(node, false, "not registered with the master", sim_time);
        continue;
      }
      known = uris_.emplace(node, static_cast<std::string>(payload)).first;
    }
    std::string host;
    std::uint32_t port = 0;
    std::string why;
    if (!ros::network::splitURI(known->second, host, port))
      why = "the master lists a bad URI '" + known->second + "'";
    else
      why = tryConnect(host, port, 500);
    if (!why.empty())
      uris_.erase(known);
    watch_.notePing(node, why.empty(), why, sim_time);
  }
}

}  // namespace node
}  // namespace avsp
