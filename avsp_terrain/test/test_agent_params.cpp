// The ~agents parser (ros/agent_params.hpp) without a master: a full list, defaults, and malformed
// entries each naming the key.
#include <string>

#include <gtest/gtest.h>

#include "avsp_terrain/ros/agent_params.hpp"

using namespace avsp::terrain;
using avsp::terrain::node::parseAgents;
using XmlRpc::XmlRpcValue;

namespace
{
XmlRpcValue point(double x, double y)
{
  XmlRpcValue p;
  p[0] = x;
  p[1] = y;
  return p;
}

XmlRpcValue goodDeer()
{
  XmlRpcValue d;
  d["name"] = std::string("deer");
  d["type"] = std::string("deer");
  d["path"][0] = point(10.0, -8.0);
  d["path"][1] = point(10.0, 8.0);
  d["speed"] = 4.0;
  d["start_time"] = 1;  // an int is a number too
  return d;
}

std::string errorOf(XmlRpcValue list)
{
  try
  {
    parseAgents(list);
  }
  catch (const avsp::node::StartupError& e)
  {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(AgentParams, ParsesEveryKeyWithDefaults)
{
  XmlRpcValue list;
  list[0] = goodDeer();
  XmlRpcValue walker;
  walker["name"] = std::string("walker");
  walker["type"] = std::string("pedestrian");
  walker["path"][0] = point(0, 0);
  walker["path"][1] = point(5, 0);
  walker["path"][2] = point(5, 5);
  walker["speed"] = 1.4;
  walker["loop"] = true;
  list[1] = walker;
  XmlRpcValue bystander;
  bystander["name"] = std::string("bystander");
  bystander["type"] = std::string("pedestrian");
  bystander["path"][0] = point(1, 2);
  bystander["yaw"] = 1.5;
  list[2] = bystander;
  const std::vector<AgentSpec> s = parseAgents(list);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0].name, "deer");
  EXPECT_EQ(s[0].type, AgentType::kDeer);
  EXPECT_EQ(s[0].path.size(), 2u);
  EXPECT_EQ(s[0].path[1], Eigen::Vector2d(10.0, 8.0));
  EXPECT_EQ(s[0].speed, 4.0);
  EXPECT_EQ(s[0].start_time, 1.0);
  EXPECT_FALSE(s[0].loop);
  EXPECT_TRUE(s[1].loop);
  EXPECT_EQ(s[1].type, AgentType::kPedestrian);
  EXPECT_EQ(s[2].speed, 0.0);
  EXPECT_EQ(s[2].yaw, 1.5);
}

TEST(AgentParams, MalformedEntriesNameTheKey)
{
  auto withField = [](const std::string& key, XmlRpcValue value) {
    XmlRpcValue list;
    list[0] = goodDeer();
    list[0][key] = value;
    return list;
  };
  EXPECT_EQ(errorOf(withField("speed", XmlRpcValue(-1.0))),
            "parameter ~agents[0].speed: must be finite and >= 0 m/s, got -1");
  EXPECT_EQ(errorOf(withField("speed", XmlRpcValue(std::string("fast")))),
            "parameter ~agents[0].speed: must be a number");
  EXPECT_EQ(errorOf(withField("type", XmlRpcValue(std::string("moose")))),
            "parameter ~agents[0].type: unknown agent type 'moose' (deer, pedestrian or truck)");
  EXPECT_EQ(errorOf(withField("loop", XmlRpcValue(1))), "parameter ~agents[0].loop: must be true or false");
  EXPECT_EQ(errorOf(withField("colour", XmlRpcValue(1))).rfind("parameter ~agents[0].colour: unknown key", 0), 0u);
  XmlRpcValue bad_point;
  bad_point[0] = point(0, 0);
  bad_point[1][0] = 1.0;
  EXPECT_EQ(errorOf(withField("path", bad_point)),
            "parameter ~agents[0].path[1]: must be a pair of numbers [x, y] (m)");
  XmlRpcValue missing;
  missing[0] = goodDeer();
  missing[0].clear();
  missing[0]["name"] = std::string("deer");
  missing[0]["path"][0] = point(0, 0);
  EXPECT_EQ(errorOf(missing), "parameter ~agents[0].type: missing (required)");
  XmlRpcValue twice;
  twice[0] = goodDeer();
  twice[1] = goodDeer();
  EXPECT_EQ(errorOf(twice), "parameter ~agents[1].name: 'deer' is used by another agent");
  EXPECT_EQ(errorOf(XmlRpcValue(3)).rfind("parameter ~agents must be a list", 0), 0u);
  XmlRpcValue not_map;
  not_map[0] = 5;
  EXPECT_EQ(errorOf(not_map), "parameter ~agents[0] must be a map {name, type, path, ...}");
}
