// run_recorder: the main job's results writer (README.md, "Run recorder"). The node is avsp_ros'
// RunRecorder; this main only sets up output and signals, constructs it and spins.
#include <cstdio>

#include <ros/init.h>

#include <avsp_terrain/ros/node_main.hpp>

#include "avsp/ros/run_recorder.hpp"

int main(int argc, char** argv)
{
  // Progress lines are for people watching a log file too: one line each, as it comes.
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  // Interrupts are the run's to handle: the results so far are written, then the node exits.
  ros::init(argc, argv, "run_recorder", ros::init_options::NoSigintHandler);
  avsp::node::RunRecorder::handleInterrupts();
  return avsp::node::constructAndSpin<avsp::node::RunRecorder>("run_recorder");
}
