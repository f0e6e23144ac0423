#pragma once
/**
 * @file run_recorder.hpp
 * @brief run_recorder as a class (README.md, "Run recorder"): the main job's results writer.
 *        Records every listed vehicle's odometry and telemetry and the ruts on sim time, watches
 *        the run's nodes (RunSupervisor), and when /clock reaches ~duration writes ~output_dir
 *        (summary.json, CSVs, .npy grids, the PNGs); a failed or interrupted run writes what it
 *        has with "aborted" in summary.json.
 */
#include <memory>

#include <ros/node_handle.h>

namespace avsp
{
namespace node
{
class RunRecorder
{
public:
  /**
   * @brief Reads the parameters (vehicles, output folder, duration, the terrain for the rut
   *        map), starts watching the run's nodes, subscribes.
   * @pre /use_sim_time is true
   * @throw avsp::node::StartupError naming the parameter
   */
  RunRecorder(ros::NodeHandle& nh, ros::NodeHandle& pnh);
  ~RunRecorder();
  RunRecorder(const RunRecorder&) = delete;
  RunRecorder& operator=(const RunRecorder&) = delete;

  /**
   * @brief SIGINT and SIGTERM end the recording: the loop writes the results so far and the node
   *        exits 128 + signal. Call once, after ros::init() with ros::init_options::NoSigintHandler.
   */
  static void handleInterrupts();

  /**
   * @brief Records until /clock reaches ~duration, then writes the results; stops early, writing
   *        what it has, when the run fails or is interrupted.
   * @return the exit code: 0 done, 1 failed (a node died, or results not written), 128 + signal
   */
  int spin();

private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace node
}  // namespace avsp
