/**
 * @file output_file.hpp
 * @brief Where a save request may write, and writing so that success means the bytes are on disk.
 *
 * The save_map services of terrain_node and sensors_node take a path from whoever calls them.
 * These functions decide which paths are acceptable (inside the node's output folder, no
 * control characters, no "..", only regular files) and write through a temporary sibling
 * that is renamed into place only after every write, flush and close succeeded, so a failed
 * save neither reports success nor leaves a partial file or clobbers an earlier good one.
 * ROS-free.
 */
#pragma once

#include <functional>
#include <stdexcept>
#include <string>

namespace avsp
{
namespace terrain
{
/// A refused output path or a failed write; what() names the path and the reason.
class OutputFileError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/// Where save requests may write.
struct OutputFolder
{
  /// Absolute folder; relative requests resolve under it, absolute ones must lie inside it.
  std::string directory;
  /// When true, absolute paths outside `directory` are accepted too (the operator's choice).
  bool allow_absolute_paths = false;
};

/// Longest accepted request, in bytes (Linux PATH_MAX less the temporary suffix).
constexpr std::size_t kMaxOutputPathLength = 4000;

/// The folder a node writes to when nobody names one: $ROS_HOME, else $HOME/.ros (where
/// roslaunch runs its nodes).
std::string defaultOutputFolder();

/**
 * @brief Checks an output folder at start-up: absolute, no "..", creates it (and its parents)
 *        when missing.
 * @return the folder without a trailing '/'
 * @throw OutputFileError naming the folder and the reason (relative, not a directory,
 *        cannot be created)
 */
std::string prepareOutputFolder(const std::string& directory);

/**
 * @brief The absolute path a save request names, or why it may not be written.
 *
 * Refused: an empty path; a NUL or other control character (below 0x20, 0x7f); a "." or ".."
 * component; a path longer than kMaxOutputPathLength; an absolute path outside
 * `folder.directory` unless `folder.allow_absolute_paths`; a parent that is not an existing
 * directory; an existing target that is not a regular file (a symbolic link, device, pipe,
 * directory). Nothing is created or changed.
 * @throw OutputFileError naming the request and the reason
 */
std::string resolveOutputPath(const std::string& requested, const OutputFolder& folder);

/**
 * @brief Runs `write(temporary)` for a temporary file beside `path`, then renames it to `path`.
 *
 * `write` must throw if any of its writes fails. On any failure the temporary is removed and
 * the exception propagates; `path` is then untouched.
 * @throw OutputFileError if the rename fails; whatever `write` throws
 */
void writeThroughTemporary(const std::string& path, const std::function<void(const std::string&)>& write);

/**
 * @brief Writes `bytes` to `path`, checking every write, the flush to disk (fsync) and the close.
 * @throw OutputFileError naming the path and the failing call (e.g. "No space left on device")
 */
void writeBytes(const std::string& path, const std::string& bytes);

}  // namespace terrain
}  // namespace avsp
