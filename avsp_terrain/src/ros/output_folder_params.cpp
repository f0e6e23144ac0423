#include "avsp_terrain/ros/output_folder_params.hpp"

#include <string>

#include "avsp_terrain/ros/node_params.hpp"

namespace avsp
{
namespace terrain
{
namespace node
{
OutputFolder outputFolderFromParams(const ros::NodeHandle& pnh)
{
  OutputFolder folder;
  try
  {
    folder.directory = prepareOutputFolder(avsp::node::stringParam(pnh, "output_dir", defaultOutputFolder()));
  }
  catch (const OutputFileError& e)
  {
    throw avsp::node::StartupError(std::string("parameter ~output_dir: ") + e.what());
  }
  folder.allow_absolute_paths = avsp::node::boolParam(pnh, "allow_absolute_paths", false);
  return folder;
}

}  // namespace node
}  // namespace terrain
}  // namespace avsp
