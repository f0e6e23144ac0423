// The foundation demo's job: load and validate every vehicle of the team (URDF + YAML,
// through avsp_dynamics), wait until TF carries every body and sensor frame of every
// vehicle under its prefixed name, check the TF geometry against the model, print a
// summary, and exit 0 only if all of it holds.
//
// Parameters (private):
//   vehicles   list of {name: <vehicle>, model: <model>}            required, non-empty
//   config_dir folder with <model>.yaml vehicle configs             required
//   timeout    s (wall clock) to wait for each vehicle's frames     default 20, > 0
//   tolerance  m, allowed TF vs model distance for a frame           default 0.001, > 0
#include <cmath>
#include <cstdio>
#include <exception>
#include <set>
#include <string>
#include <vector>

#include <avsp_dynamics/vehicle_model.hpp>
#include <avsp_terrain/ros/node_params.hpp>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

namespace
{
struct TeamMember
{
  std::string name;
  std::string model;
};

bool readTeam(const ros::NodeHandle& pnh, std::vector<TeamMember>& team)
{
  try
  {
    for (const avsp::node::VehicleListEntry& e :
         avsp::node::vehicleListParam(pnh, true, { "name", "model", "x", "y", "yaw" }, "{name, model}"))
      team.push_back({ e.name, e.model });
  }
  catch (const avsp::node::StartupError& e)
  {
    ROS_FATAL("team_check: %s", e.what());
    return false;
  }
  return true;
}
}  // namespace

int main(int argc, char** argv)
{
  ros::init(argc, argv, "team_check");
  ros::NodeHandle pnh("~");
  std::vector<TeamMember> team;
  std::string config_dir;
  double timeout = 20.0, tolerance = 0.001;
  try
  {
    timeout = avsp::node::boundedParam(pnh, "timeout", 20.0, 1e-3, 1e6);
    tolerance = avsp::node::boundedParam(pnh, "tolerance", 0.001, 1e-9, 1e3);
    config_dir = avsp::node::stringParam(pnh, "config_dir", "");
  }
  catch (const std::exception& e)
  {
    ROS_FATAL("team_check: %s", e.what());
    return 1;
  }
  if (!readTeam(pnh, team))
    return 1;
  if (config_dir.empty())
  {
    ROS_FATAL("team_check: ~config_dir (folder of <model>.yaml) is required");
    return 1;
  }

  std::vector<avsp::dynamics::VehicleModel> models;
  for (const TeamMember& m : team)
  {
    try
    {
      models.push_back(avsp::dynamics::loadVehicleModel(config_dir + "/" + m.model + ".yaml"));
    }
    catch (const avsp::dynamics::ConfigError& e)
    {
      ROS_FATAL("team_check: vehicle '%s': %s", m.name.c_str(), e.what());
      return 1;
    }
  }

  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);
  bool ok = true;
  std::size_t frames_checked = 0;
  std::printf("\n%-10s %-10s %-11s %9s %6s %7s  %s\n", "vehicle", "model", "drive", "mass[kg]", "gear", "frames",
              "lidar height above base_link [m]");
  for (std::size_t k = 0; k < team.size() && ros::ok(); ++k)
  {
    const auto& model = models[k];
    const std::string prefix = team[k].name + "/";
    // Every massive body and every sensor mount, where the model says it is.
    std::vector<std::pair<std::string, Eigen::Vector3d>> expected;
    for (const auto& b : model.bodies)
      expected.emplace_back(b.link, b.rest_position);
    for (const auto& s : model.sensor_mounts)
      expected.emplace_back(s.first, s.second);
    std::size_t found = 0;
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout);
    for (const auto& [link, position] : expected)
    {
      std::string error;
      while (!buffer.canTransform(prefix + "base_link", prefix + link, ros::Time(0)) && ros::ok() &&
             ros::WallTime::now() < deadline)
        ros::WallDuration(0.05).sleep();  // waiting for data to arrive, bounded by ~timeout
      if (!buffer.canTransform(prefix + "base_link", prefix + link, ros::Time(0), &error))
      {
        ROS_ERROR("team_check: no TF for %s%s after %.1f s: %s", prefix.c_str(), link.c_str(), timeout, error.c_str());
        ok = false;
        continue;
      }
      const auto t = buffer.lookupTransform(prefix + "base_link", prefix + link, ros::Time(0)).transform.translation;
      const double err = (Eigen::Vector3d(t.x, t.y, t.z) - position).norm();
      if (err > tolerance)
      {
        ROS_ERROR("team_check: %s%s is %.4f m from where the model puts it", prefix.c_str(), link.c_str(), err);
        ok = false;
        continue;
      }
      ++found;
    }
    // map -> odom comes from another process (world_frames.launch) than the vehicle's frames:
    // it may arrive after them, so it is waited for within the same deadline.
    while (!buffer.canTransform("map", prefix + "base_link", ros::Time(0)) && ros::ok() &&
           ros::WallTime::now() < deadline)
      ros::WallDuration(0.05).sleep();
    if (!buffer.canTransform("map", prefix + "base_link", ros::Time(0)))
    {
      ROS_ERROR("team_check: no TF map -> %sbase_link", prefix.c_str());
      ok = false;
    }
    frames_checked += found;
    const std::size_t gear = model.drive_type == avsp::dynamics::DriveType::kTracked
                                 ? model.tracks[0].road_wheels.size() + model.tracks[1].road_wheels.size()
                                 : model.wheels.size();
    std::printf("%-10s %-10s %-11s %9.1f %6zu %3zu/%-3zu  %.2f\n", team[k].name.c_str(), team[k].model.c_str(),
                avsp::dynamics::toString(model.drive_type), model.total_mass, gear, found, expected.size(),
                model.sensor_mounts.at("lidar").z());
  }
  if (!ok || !ros::ok())
  {
    std::printf("\nteam check FAILED\n");
    return 1;
  }
  std::printf("\nteam check passed: %zu vehicles validated, %zu frames on TF where their models put them\n",
              team.size(), frames_checked);
  return 0;
}
