#pragma once
/**
 * @file output_folder_params.hpp
 * @brief The ROS side of output_file.hpp (this header includes ROS): ~output_dir and
 *        ~allow_absolute_paths, read the same way by every node with a save_map service.
 */
#include <string>

#include <ros/node_handle.h>

#include <avsp_msgs/node_params.hpp>

#include "avsp_terrain/output_file.hpp"

namespace avsp
{
namespace terrain
{
/// Reads ~output_dir (default defaultOutputFolder(), created if missing) and ~allow_absolute_paths.
/// @throw avsp::msgs::StartupError naming the parameter
inline OutputFolder outputFolderFromParams(const ros::NodeHandle& pnh)
{
  OutputFolder folder;
  try
  {
    folder.directory = prepareOutputFolder(avsp::msgs::stringParam(pnh, "output_dir", defaultOutputFolder()));
  }
  catch (const OutputFileError& e)
  {
    throw avsp::msgs::StartupError(std::string("parameter ~output_dir: ") + e.what());
  }
  folder.allow_absolute_paths = avsp::msgs::boolParam(pnh, "allow_absolute_paths", false);
  return folder;
}

}  // namespace terrain
}  // namespace avsp
