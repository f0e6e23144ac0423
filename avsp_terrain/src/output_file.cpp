// Output paths for save requests and checked writes (output_file.hpp).
#include "avsp_terrain/output_file.hpp"

#include <atomic>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace avsp
{
namespace terrain
{
namespace
{
[[noreturn]] void refuse(const std::string& path, const std::string& why)
{
  throw OutputFileError("path '" + path + "': " + why);
}

/// The request as printable text: control characters shown as \xNN, so a refusal can quote it.
std::string printable(const std::string& s)
{
  std::string out;
  for (unsigned char c : s)
  {
    if (c < 0x20 || c == 0x7f)
    {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      out += hex;
    }
    else
      out += static_cast<char>(c);
  }
  return out;
}

/// Splits an absolute path into its components; refuses "." and ".." (a lexical check must
/// be enough to keep a request inside its folder) and a trailing '/'.
std::vector<std::string> components(const std::string& path, const std::string& shown)
{
  std::vector<std::string> parts;
  std::size_t start = 1;
  while (start <= path.size())
  {
    const std::size_t slash = path.find('/', start);
    const std::size_t end = slash == std::string::npos ? path.size() : slash;
    const std::string part = path.substr(start, end - start);
    if (part == "." || part == "..")
      refuse(shown, "'.' and '..' components are not accepted");
    if (!part.empty())
      parts.push_back(part);
    else if (slash == std::string::npos)
      break;
    start = end + 1;
  }
  return parts;
}

std::string join(const std::vector<std::string>& parts, std::size_t count)
{
  std::string out;
  for (std::size_t k = 0; k < count; ++k)
    out += "/" + parts[k];
  return out.empty() ? "/" : out;
}

std::string fileType(mode_t mode)
{
  if (S_ISLNK(mode))
    return "a symbolic link";
  if (S_ISDIR(mode))
    return "a directory";
  if (S_ISCHR(mode) || S_ISBLK(mode))
    return "a device";
  if (S_ISFIFO(mode))
    return "a pipe";
  if (S_ISSOCK(mode))
    return "a socket";
  return "not a regular file";
}

void checkCharacters(const std::string& path, const std::string& shown)
{
  for (unsigned char c : path)
    if (c < 0x20 || c == 0x7f)
      refuse(shown, "contains a control character (NUL, newline, ...)");
}

std::string realPath(const std::string& path)
{
  std::unique_ptr<char, decltype(&std::free)> resolved(realpath(path.c_str(), nullptr), &std::free);
  return resolved ? std::string(resolved.get()) : std::string();
}

bool inside(const std::string& path, const std::string& folder)
{
  return folder == "/" || path == folder || path.compare(0, folder.size() + 1, folder + "/") == 0;
}
}  // namespace

std::string defaultOutputFolder()
{
  const char* ros_home = std::getenv("ROS_HOME");
  if (ros_home != nullptr && *ros_home != '\0')
    return ros_home;
  const char* home = std::getenv("HOME");
  return std::string(home != nullptr && *home != '\0' ? home : "/tmp") + "/.ros";
}

std::string prepareOutputFolder(const std::string& directory)
{
  const std::string shown = printable(directory);
  if (directory.empty() || directory[0] != '/')
    refuse(shown, "the output folder must be an absolute path");
  checkCharacters(directory, shown);
  const std::vector<std::string> parts = components(directory, shown);
  for (std::size_t k = 1; k <= parts.size(); ++k)
  {
    const std::string prefix = join(parts, k);
    if (::mkdir(prefix.c_str(), 0775) != 0 && errno != EEXIST)
      refuse(shown, "cannot create folder '" + prefix + "': " + std::strerror(errno));
  }
  const std::string folder = join(parts, parts.size());
  struct stat st;
  if (::stat(folder.c_str(), &st) != 0)
    refuse(shown, std::string("cannot read the output folder: ") + std::strerror(errno));
  if (!S_ISDIR(st.st_mode))
    refuse(shown, "the output folder is not a directory");
  return folder;
}

std::string resolveOutputPath(const std::string& requested, const OutputFolder& folder)
{
  const std::string shown = printable(requested);
  if (requested.empty())
    refuse(shown, "empty");
  if (requested.size() > kMaxOutputPathLength)
    refuse(shown.substr(0, 80) + "...", "longer than " + std::to_string(kMaxOutputPathLength) + " bytes");
  checkCharacters(requested, shown);
  if (requested.back() == '/')
    refuse(shown, "names a folder, not a file");
  const bool absolute = requested[0] == '/';
  const std::string full = absolute ? requested : folder.directory + "/" + requested;
  const std::vector<std::string> parts = components(full, shown);
  if (parts.empty())
    refuse(shown, "names a folder, not a file");
  const std::string path = join(parts, parts.size());
  const std::string parent = join(parts, parts.size() - 1);

  struct stat st;
  if (::stat(parent.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
    refuse(shown, "folder '" + parent + "' does not exist");
  if (!folder.allow_absolute_paths)
  {
    // Lexically inside, and no symbolic link on the way leads out of the folder.
    const std::string real_folder = realPath(folder.directory);
    const std::string real_parent = realPath(parent);
    if (!inside(path, folder.directory) || real_folder.empty() || real_parent.empty() ||
        !inside(real_parent, real_folder))
      refuse(shown,
             "outside the output folder '" + folder.directory + "' (set ~allow_absolute_paths to write elsewhere)");
  }
  if (::lstat(path.c_str(), &st) == 0)
  {
    if (!S_ISREG(st.st_mode))
      refuse(shown, "exists and is " + fileType(st.st_mode) + "; only regular files are overwritten");
  }
  else if (errno != ENOENT)
    refuse(shown, std::string("cannot inspect the target: ") + std::strerror(errno));
  return path;
}

void writeThroughTemporary(const std::string& path, const std::function<void(const std::string&)>& write)
{
  static std::atomic<unsigned> counter{ 0 };
  const std::size_t slash = path.rfind('/');
  const std::string folder = path.substr(0, slash + 1);
  std::string name = path.substr(slash + 1);
  // The temporary keeps the extension (writers choose the format by it) and fits NAME_MAX.
  if (name.size() > 200)
    name = name.substr(name.size() - 200);
  const std::string temporary =
      folder + ".partial-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + "-" + name;
  try
  {
    write(temporary);
  }
  catch (...)
  {
    std::remove(temporary.c_str());
    throw;
  }
  if (std::rename(temporary.c_str(), path.c_str()) != 0)
  {
    const int e = errno;
    std::remove(temporary.c_str());
    refuse(path, std::string("cannot move the written file into place: ") + std::strerror(e));
  }
}

void writeBytes(const std::string& path, const std::string& bytes)
{
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0664);
  if (fd < 0)
    refuse(path, std::string("cannot open for writing: ") + std::strerror(errno));
  std::size_t done = 0;
  while (done < bytes.size())
  {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR)
      continue;
    if (n <= 0)
    {
      const int e = n < 0 ? errno : EIO;
      ::close(fd);
      refuse(path, std::string("write failed: ") + std::strerror(e));
    }
    done += static_cast<std::size_t>(n);
  }
  // fsync reports a deferred write error (e.g. a full disk); a device such as /dev/full
  // cannot sync (EINVAL), and it already failed its write above.
  if (::fsync(fd) != 0 && errno != EINVAL && errno != EROFS)
  {
    const int e = errno;
    ::close(fd);
    refuse(path, std::string("flush to disk failed: ") + std::strerror(e));
  }
  if (::close(fd) != 0)
    refuse(path, std::string("close failed: ") + std::strerror(errno));
}

}  // namespace terrain
}  // namespace avsp
