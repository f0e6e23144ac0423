#include "avsp_sensors/camera_rig.hpp"

#include <chrono>
#include <set>
#include <stdexcept>

#include "avsp_sensors/random.hpp"

namespace avsp
{
namespace sensors
{
CameraRig::CameraRig(const std::vector<CameraConfig>& cameras, std::uint32_t body_id, std::uint64_t seed)
  : body_id_(body_id), seed_(seed)
{
  std::set<std::string> names;
  for (const CameraConfig& c : cameras)
  {
    if (!names.insert(c.name).second)
      throw std::invalid_argument("CameraConfig '" + c.name + "': name used twice");
    cameras_.emplace_back(c);  // validates
    clocks_.emplace_back(c.rate);
  }
}

Eigen::Isometry3d CameraRig::opticalMount(std::size_t k) const
{
  Eigen::Isometry3d m = cameras_.at(k).config().mount;
  m.linear() = m.linear() * opticalFromBody();
  return m;
}

std::vector<CameraOutput> CameraRig::update(const VehicleState& state, const Scene& scene,
                                            const CameraMaterials& materials, const CameraEnvironment& env,
                                            unsigned threads)
{
  validateState(state, "CameraRig::update");
  std::vector<CameraOutput> out;
  for (std::size_t k = 0; k < cameras_.size(); ++k)
  {
    if (!clocks_[k].due(state.time))
      continue;
    clocks_[k].taken(state.time);
    const auto start = std::chrono::steady_clock::now();
    CameraOutput o;
    o.index = k;
    o.time = state.time;
    o.optical_pose = state.pose * opticalMount(k);
    o.frame = cameras_[k].render(scene, materials, o.optical_pose, env, threads, body_id_,
                                 streamKey(seed_, k, clocks_[k].index(state.time)));
    o.cost = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    out.push_back(std::move(o));
  }
  return out;
}

}  // namespace sensors
}  // namespace avsp
