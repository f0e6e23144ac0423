/**
 * @file input_file.hpp
 * @brief Reading an input file (a vehicle's YAML or URDF, soils.yaml, a DEM sidecar, a terrain
 *        file) only when it is a regular file of a plausible size: /dev/zero would read forever,
 *        a FIFO blocks, a directory is no file, and a huge file only costs memory. ROS-free.
 */
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

namespace avsp
{
namespace terrain
{
/// Why an input file is not read, without its path (each caller adds the path in its own error).
class InputFileRefused : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/**
 * @brief The whole content of `path`, which must be a regular file of at most `max_bytes`
 *        (checked before it is opened); a file that becomes a FIFO after the check is not waited
 *        on, and one that grows beyond `max_bytes` while read is refused.
 * @param what what the file is, for the message ("a vehicle file")
 * @throw InputFileRefused e.g. "is a FIFO (named pipe), not a regular file: refused without reading it"
 */
std::string readInputFile(const std::string& path, std::uint64_t max_bytes, const std::string& what);

}  // namespace terrain
}  // namespace avsp
