#include "avsp_dynamics/collision_counter.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace avsp
{
namespace dynamics
{
CollisionCounter::CollisionCounter(double separation, double travel) : separation_(separation), travel_(travel)
{
  if (!(separation >= 0.0 && std::isfinite(separation)))
    throw std::invalid_argument("CollisionCounter: separation must be finite and >= 0 s, got " +
                                std::to_string(separation));
  if (!(travel >= 0.0 && std::isfinite(travel)))
    throw std::invalid_argument("CollisionCounter: travel must be finite and >= 0 m, got " + std::to_string(travel));
}

bool CollisionCounter::update(int rigid_contacts, double time, const Eigen::Vector3d& position)
{
  // Horizontal only: after an impact the body heaves and pitches on its suspension for a
  // second (decimetres of vertical motion) while it has not moved away from the obstacle.
  if (touched_)
    travelled_ += (position - last_position_).head<2>().norm();
  last_position_ = position;
  in_contact_ = rigid_contacts > 0;
  if (!in_contact_)
    return false;
  const bool begins = !touched_ || (time - last_contact_ >= separation_ && travelled_ >= travel_);
  touched_ = true;
  last_contact_ = time;
  travelled_ = 0.0;
  if (begins)
    ++count_;
  return begins;
}

}  // namespace dynamics
}  // namespace avsp
