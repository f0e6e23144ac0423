// lockstep_clock: the clock of a partitioned run (README.md, "lockstep_clock"). The node is
// avsp_dynamics_ros' LockstepClock; this main only constructs it and spins.
#include <avsp_terrain/ros/node_main.hpp>

#include "avsp_dynamics/ros/lockstep_clock.hpp"

int main(int argc, char** argv)
{
  return avsp::node::runNode<avsp::dynamics::node::LockstepClock>(argc, argv, "lockstep_clock");
}
