// rostest of start_gate (test/start_gate.test): the gate must not start the physics while any
// publisher the master lists lacks a connection to a subscriber the master lists, on any topic
// (not only odometry). A lost /clock tick or V2V batch deadlocks a lockstep run.
//
// The test plays both ends of a topic, /gate_probe, through the master's XML-RPC API: a
// publisher /fake_pub and a subscriber /fake_sub whose node API is the test's own small
// XML-RPC server. That server answers start_gate's getBusInfo with no connection until the
// test has seen several such polls, then with one: the gate's signal on /gate/open must come
// only after that. The gate publishes nothing else (no command in a vehicle's namespace: a
// vehicle's avt_341/cmd_vel belongs to whatever drives it).
#include <algorithm>
#include <atomic>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <ros/master.h>
#include <ros/ros.h>
#include <std_msgs/Empty.h>
#include <xmlrpcpp/XmlRpcServer.h>
#include <xmlrpcpp/XmlRpcServerMethod.h>
#include <xmlrpcpp/XmlRpcValue.h>

namespace
{
const char* const kTopic = "/gate_probe";

/// The fake nodes' API: getBusInfo (counted; connected once `connected` is set) and the
/// master's publisherUpdate.
class FakeNodeApi
{
public:
  FakeNodeApi() : bus_info_(this), publisher_update_(this)
  {
    server_.bindAndListen(0);
    port_ = server_.get_port();
    thread_ = std::thread([this] {
      while (running_)
        server_.work(0.02);
    });
  }
  ~FakeNodeApi()
  {
    running_ = false;
    thread_.join();
    server_.shutdown();
  }
  std::string uri() const { return "http://127.0.0.1:" + std::to_string(port_) + "/"; }

  std::atomic<int> polls{ 0 };           ///< getBusInfo calls so far
  std::atomic<bool> connected{ false };  ///< what getBusInfo reports

private:
  struct BusInfo : XmlRpc::XmlRpcServerMethod
  {
    explicit BusInfo(FakeNodeApi* api) : XmlRpc::XmlRpcServerMethod("getBusInfo", &api->server_), api(api) {}
    void execute(XmlRpc::XmlRpcValue&, XmlRpc::XmlRpcValue& result) override
    {
      XmlRpc::XmlRpcValue list;
      list.setSize(0);
      if (api->connected)
      {
        XmlRpc::XmlRpcValue c;
        c[0] = 1;
        c[1] = std::string("/fake_sub");
        c[2] = std::string("o");
        c[3] = std::string("TCPROS");
        c[4] = std::string(kTopic);
        c[5] = true;
        list[0] = c;
      }
      result[0] = 1;
      result[1] = std::string("bus info");
      result[2] = list;
      ++api->polls;
    }
    FakeNodeApi* api;
  };
  struct PublisherUpdate : XmlRpc::XmlRpcServerMethod
  {
    explicit PublisherUpdate(FakeNodeApi* api) : XmlRpc::XmlRpcServerMethod("publisherUpdate", &api->server_) {}
    void execute(XmlRpc::XmlRpcValue&, XmlRpc::XmlRpcValue& result) override
    {
      result[0] = 1;
      result[1] = std::string("");
      result[2] = 0;
    }
  };

  XmlRpc::XmlRpcServer server_;
  BusInfo bus_info_;
  PublisherUpdate publisher_update_;
  int port_ = 0;
  std::atomic<bool> running_{ true };
  std::thread thread_;
};

/// Calls the master's `method` with these string arguments.
bool masterCall(const std::string& method, const std::vector<std::string>& strings)
{
  XmlRpc::XmlRpcValue args, result, payload;
  for (std::size_t k = 0; k < strings.size(); ++k)
    args[static_cast<int>(k)] = strings[k];
  return ros::master::execute(method, args, result, payload, false);
}

TEST(StartGate, WaitsUntilEveryTopicsSubscribersAreConnected)
{
  FakeNodeApi api;
  ASSERT_TRUE(masterCall("registerSubscriber", { "/fake_sub", kTopic, "std_msgs/Empty", api.uri() }));
  ASSERT_TRUE(masterCall("registerPublisher", { "/fake_pub", kTopic, "std_msgs/Empty", api.uri() }));

  ros::NodeHandle nh;
  std::atomic<int> signals{ 0 };  // signals on /gate/open
  ros::Subscriber sub =
      nh.subscribe<std_msgs::Empty>("/gate/open", 1, [&signals](const std_msgs::Empty::ConstPtr&) { ++signals; });
  ros::AsyncSpinner spinner(1);
  spinner.start();

  // The gate polls every 0.05 s (wall); a hang guard of 60 s.
  const auto waitFor = [](const std::function<bool()>& done) {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(60.0);
    while (!done() && ros::WallTime::now() < deadline)
      ros::WallDuration(0.01).sleep();
    return done();
  };
  waitFor([&] { return api.polls >= 10 || signals > 0; });
  // Ten answers without the connection: the gate must still hold the physics.
  ASSERT_EQ(signals, 0) << "start_gate released while /fake_sub was not connected on " << kTopic << " (after "
                        << api.polls << " polls)";
  ASSERT_GE(api.polls, 10) << "start_gate did not ask /fake_pub for its connections";
  api.connected = true;
  EXPECT_TRUE(waitFor([&] { return signals > 0; })) << "start_gate did not release once every topic was connected";
  // What the gate publishes, from the master: its log and the signal, nothing else.
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  ASSERT_TRUE(ros::master::execute("getSystemState", args, result, payload, true));
  std::vector<std::string> published;
  for (int t = 0; t < payload[0].size(); ++t)
    for (int n = 0; n < payload[0][t][1].size(); ++n)
      if (static_cast<std::string>(payload[0][t][1][n]) == "/gate")
        published.push_back(static_cast<std::string>(payload[0][t][0]));
  std::sort(published.begin(), published.end());
  EXPECT_EQ(published, (std::vector<std::string>{ "/gate/open", "/rosout" }));
  spinner.stop();
  masterCall("unregisterPublisher", { "/fake_pub", kTopic, api.uri() });
  masterCall("unregisterSubscriber", { "/fake_sub", kTopic, api.uri() });
}
}  // namespace

int main(int argc, char** argv)
{
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_start_gate");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
