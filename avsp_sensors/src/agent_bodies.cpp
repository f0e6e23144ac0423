#include "avsp_sensors/agent_bodies.hpp"

#include <Eigen/Geometry>

namespace avsp
{
namespace sensors
{
std::vector<Body> agentBodies(const terrain::Agent& agent, double t, std::uint32_t id,
                              const AgentReflectivities& reflectivities)
{
  const terrain::AgentState s = agent.state(t);
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(s.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d omega(0.0, 0.0, s.yaw_rate);
  std::vector<Body> bodies;
  for (const terrain::AgentBox& box : terrain::agentBoxes(agent.spec().type))
  {
    Body b;
    b.primitive.shape = Shape::kBox;
    b.primitive.half_extents = 0.5 * box.size;
    b.primitive.centre = s.position + rotation * box.centre;
    b.primitive.rotation = rotation;
    b.primitive.id = id;
    b.primitive.reflectivity = reflectivities.of(agent.spec().type);
    b.velocity = s.velocity + omega.cross(b.primitive.centre - s.position);
    b.angular_velocity = omega;
    bodies.push_back(b);
  }
  return bodies;
}

}  // namespace sensors
}  // namespace avsp
