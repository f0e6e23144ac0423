#include "avsp_terrain/input_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace avsp
{
namespace terrain
{
namespace
{
std::string fileKind(unsigned mode)
{
  if (S_ISDIR(mode))
    return "a directory";
  if (S_ISCHR(mode))
    return "a character device";
  if (S_ISBLK(mode))
    return "a block device";
  if (S_ISFIFO(mode))
    return "a FIFO (named pipe)";
  if (S_ISSOCK(mode))
    return "a socket";
  return "not a regular file";
}

std::string byteSize(std::uint64_t bytes)
{
  if (bytes >= (1u << 20) && bytes % (1u << 20) == 0)
    return std::to_string(bytes >> 20) + " MiB";
  return std::to_string(bytes) + " bytes";
}

void checkStat(const struct stat& st, std::uint64_t max_bytes, const std::string& what)
{
  if (!S_ISREG(st.st_mode))
    throw InputFileRefused("is " + fileKind(st.st_mode) + ", not a regular file: refused without reading it");
  if (static_cast<std::uint64_t>(st.st_size) > max_bytes)
    throw InputFileRefused("is " + std::to_string(st.st_size) + " bytes, more than the " + std::to_string(max_bytes) +
                           " (" + byteSize(max_bytes) + ") " + what + " may have: refused without reading it");
}
void checkInputFile(const std::string& path, std::uint64_t max_bytes, const std::string& what)
{
  // stat, not open: opening a device or a FIFO can itself block or have effects.
  struct stat st;
  if (::stat(path.c_str(), &st) != 0)
    throw InputFileRefused(std::string("cannot open the file (") + std::strerror(errno) + ")");
  checkStat(st, max_bytes, what);
}
}  // namespace

std::string readInputFile(const std::string& path, std::uint64_t max_bytes, const std::string& what)
{
  checkInputFile(path, max_bytes, what);
  // O_NONBLOCK: if the path became a FIFO since the stat, open returns instead of waiting for
  // a writer; fstat of what was opened then refuses it.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
  if (fd < 0)
    throw InputFileRefused(std::string("cannot open the file (") + std::strerror(errno) + ")");
  struct Closer
  {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{ fd };
  struct stat st;
  if (::fstat(fd, &st) != 0)
    throw InputFileRefused(std::string("cannot open the file (") + std::strerror(errno) + ")");
  checkStat(st, max_bytes, what);
  std::string text;
  text.reserve(static_cast<std::size_t>(st.st_size));
  char buffer[65536];
  while (true)
  {
    const ssize_t n = ::read(fd, buffer, sizeof(buffer));
    if (n < 0 && errno == EINTR)
      continue;
    if (n < 0)
      throw InputFileRefused(std::string("cannot be read (") + std::strerror(errno) + ")");
    if (n == 0)
      break;
    text.append(buffer, static_cast<std::size_t>(n));
    if (text.size() > max_bytes)
      throw InputFileRefused("grew beyond " + std::to_string(max_bytes) + " bytes (" + byteSize(max_bytes) +
                             ") while it was read");
  }
  return text;
}

}  // namespace terrain
}  // namespace avsp
