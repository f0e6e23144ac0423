#include "avsp_sensors/ros/vehicle_frames.hpp"

#include <stdexcept>

#include <urdf_model/model.h>
#include <urdf_parser/urdf_parser.h>

#include <avsp_dynamics/vehicle_model.hpp>
#include <avsp_terrain/input_file.hpp>

namespace avsp
{
namespace sensors
{
namespace node
{
namespace
{
Eigen::Isometry3d toIsometry(const urdf::Pose& p)
{
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.translation() = Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
  out.linear() =
      Eigen::Quaterniond(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z).normalized().toRotationMatrix();
  return out;
}
}  // namespace

const Eigen::Isometry3d& VehicleFrames::link(const std::string& name) const
{
  const auto it = links.find(name);
  if (it == links.end())
    throw std::invalid_argument("link '" + name + "' is not in " + urdf_path);
  return it->second;
}

VehicleFrames loadVehicleFrames(const std::string& yaml_path)
{
  const avsp::dynamics::VehicleModel model = avsp::dynamics::loadVehicleModel(yaml_path);
  VehicleFrames out;
  out.urdf_path = model.urdf_path;
  // The same file checks as the model's loader: the URDF may have changed since it read it.
  std::string text;
  try
  {
    text = avsp::terrain::readInputFile(model.urdf_path, avsp::dynamics::kMaxVehicleFileBytes, "a vehicle file");
  }
  catch (const avsp::terrain::InputFileRefused& e)
  {
    throw std::runtime_error(model.urdf_path + ": " + e.what());
  }
  const urdf::ModelInterfaceSharedPtr urdf = urdf::parseURDF(text);
  if (!urdf || !urdf->getRoot())
    throw std::runtime_error(model.urdf_path + ": cannot be parsed as URDF");
  out.root_link = urdf->getRoot()->name;
  for (const auto& kv : urdf->links_)
  {
    urdf::LinkConstSharedPtr link = kv.second;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    while (link && link->parent_joint)
    {
      pose = toIsometry(link->parent_joint->parent_to_joint_origin_transform) * pose;
      link = urdf->getLink(link->parent_joint->parent_link_name);
    }
    out.links[kv.first] = pose;
  }
  for (const avsp::dynamics::CollisionBox& b : model.collision_boxes)
  {
    BodyBox box;
    box.pose = b.pose;
    box.size = b.size;
    out.boxes.push_back(box);
  }
  return out;
}

}  // namespace node
}  // namespace sensors
}  // namespace avsp
