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

/// "a directory", "a character device", "a FIFO (named pipe)", ... for a stat mode.
std::string fileKind(unsigned mode);

/**
 * @brief Size in bytes of `path`, which must be a regular file of at most `max_bytes`.
 * @param what what the file is, for the message ("a vehicle file")
 * @throw InputFileRefused e.g. "is a FIFO (named pipe), not a regular file: refused without reading it"
 */
std::uint64_t checkInputFile(const std::string& path, std::uint64_t max_bytes, const std::string& what);

/**
 * @brief The whole content of `path` after checkInputFile; a file that becomes a FIFO after the
 *        check is not waited on, and one that grows beyond `max_bytes` while read is refused.
 * @throw InputFileRefused with the reason
 */
std::string readInputFile(const std::string& path, std::uint64_t max_bytes, const std::string& what);

/// "16 MiB" for 16 << 20; bytes otherwise.
std::string byteSize(std::uint64_t bytes);

}  // namespace terrain
}  // namespace avsp
