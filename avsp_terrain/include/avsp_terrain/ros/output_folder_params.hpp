#pragma once
/**
 * @file output_folder_params.hpp
 * @brief The ROS side of output_file.hpp: ~output_dir and ~allow_absolute_paths, read the same
 *        way by every node with a save_map service.
 */
#include <ros/node_handle.h>

#include "avsp_terrain/output_file.hpp"
#include "avsp_terrain/ros/node_params.hpp"

namespace avsp
{
namespace terrain
{
namespace node
{
/// Reads ~output_dir (default defaultOutputFolder(), created if missing) and ~allow_absolute_paths.
/// @throw avsp::node::StartupError naming the parameter
OutputFolder outputFolderFromParams(const ros::NodeHandle& pnh);

}  // namespace node
}  // namespace terrain
}  // namespace avsp
