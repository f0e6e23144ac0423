#pragma once
/**
 * @file agent_bodies.hpp
 * @brief Dynamic agents (avsp_terrain agents.hpp) as moving scene bodies: each box of the agent's
 *        type (terrain::agentBoxes) at the agent's pose at a sim time, with the rigid-body
 *        velocity of its centre for the radar's Doppler, like the other vehicles' boxes.
 */
#include <array>
#include <cstdint>
#include <vector>

#include <avsp_terrain/agents.hpp>

#include "avsp_sensors/scene.hpp"

namespace avsp
{
namespace sensors
{
/**
 * @brief Diffuse near-infrared (850-905 nm) reflectivity of each agent type, in AgentType order
 *        (deer, pedestrian, truck). Representative round values, not measurements: deer coat
 *        0.3 (brown hair and fur, dark in the NIR), clothing 0.5 (cotton and synthetics), truck
 *        paint 0.4 (the middle of painted vehicle panels); avsp_sensors/README.md "Materials".
 */
struct AgentReflectivities
{
  std::array<float, 3> types{ { 0.3f, 0.5f, 0.4f } };
  float of(terrain::AgentType type) const { return types[static_cast<std::size_t>(type)]; }
};

/**
 * @brief The agent's boxes at sim time t, each a Body with id `id` (so Ray::ignore_body never
 *        hides it unless asked), velocity v + w x (c - p) (w = yaw rate about z), the type's
 *        reflectivity.
 */
std::vector<Body> agentBodies(const terrain::Agent& agent, double t, std::uint32_t id,
                              const AgentReflectivities& reflectivities = AgentReflectivities());

}  // namespace sensors
}  // namespace avsp
