#include "avsp_terrain/dem_io.hpp"

#include <algorithm>
#include <cerrno>
#include <cfloat>
#include <climits>
#include <cmath>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <type_traits>

#include <sys/stat.h>

#include <cpl_error.h>
#include <gdal.h>
#include <ogr_srs_api.h>
#include <png.h>

#include "avsp_terrain/yaml_section.hpp"

namespace avsp
{
namespace terrain
{
namespace
{
/// Largest raster accepted: a corrupt header must not trigger a multi-gigabyte allocation,
/// and indices then fit in 32 bits.
constexpr std::uint64_t kMaxPoints = std::uint64_t{ 1 } << 31;

constexpr float kNoData = std::numeric_limits<float>::quiet_NaN();

[[noreturn]] void fail(const char* function, const std::string& path, const std::string& reason)
{
  throw DemError(std::string(function) + ": '" + path + "': " + reason);
}

/// A token from a possibly binary file, made safe and short enough for an error message.
std::string quoted(const std::string& token)
{
  constexpr std::size_t kMaxShown = 40;
  std::string out = "'";
  for (std::size_t k = 0; k < token.size() && k < kMaxShown; ++k)
  {
    const unsigned char c = static_cast<unsigned char>(token[k]);
    out += (c >= 0x20 && c < 0x7f) ? static_cast<char>(c) : '?';
  }
  if (token.size() > kMaxShown)
    out += "...";
  return out + "'";
}

struct FileCloser
{
  void operator()(std::FILE* f) const
  {
    if (f != nullptr)
      std::fclose(f);
  }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

/// Size of an existing, non-directory input file, bytes (huge if unknown); the reason names
/// what is wrong.
std::uint64_t checkInputFile(const char* function, const std::string& path)
{
  struct stat st
  {
  };
  if (::stat(path.c_str(), &st) != 0)
  {
    const int err = errno;
    if (err == ENOENT || err == ENOTDIR)
      fail(function, path, "file not found");
    fail(function, path, std::string("cannot access file: ") + std::strerror(err));
  }
  if (S_ISDIR(st.st_mode))
    fail(function, path, "is a directory, not a file");
  // A pipe or device may never end (/dev/zero) and has no size to check a header against.
  if (!S_ISREG(st.st_mode))
    fail(function, path, "is not a regular file (a device, pipe or socket)");
  return static_cast<std::uint64_t>(st.st_size);
}

FilePtr openForRead(const char* function, const std::string& path)
{
  FilePtr f(std::fopen(path.c_str(), "rb"));
  if (!f)
    fail(function, path, std::string("file is unreadable: ") + std::strerror(errno));
  return f;
}

FilePtr openForWrite(const char* function, const std::string& path)
{
  FilePtr f(std::fopen(path.c_str(), "wb"));
  if (!f)
    fail(function, path, std::string("cannot open file for writing: ") + std::strerror(errno));
  return f;
}

/// Closes a written file; a failed flush means the data did not reach the disk. A partial
/// file is removed so that nobody later loads it as a DEM.
void closeWritten(const char* function, const std::string& path, FilePtr& f)
{
  const bool write_error = std::ferror(f.get()) != 0;
  const bool close_error = std::fclose(f.release()) != 0;
  if (write_error || close_error)
  {
    std::remove(path.c_str());
    fail(function, path, "write error (disk full or I/O error?)");
  }
}

void checkDimensions(const char* function, const std::string& path, std::uint64_t columns, std::uint64_t rows,
                     std::uint64_t max_points = kMaxPoints)
{
  if (columns == 0 || rows == 0)
    fail(function, path, "zero dimensions (" + std::to_string(columns) + " x " + std::to_string(rows) + ")");
  if (columns > kMaxPoints || rows > kMaxPoints || columns * rows > kMaxPoints)
    fail(function, path,
         "dimensions " + std::to_string(columns) + " x " + std::to_string(rows) +
             " exceed the limit of 2^31 points (corrupt header?)");
  if (columns * rows > max_points)
    fail(function, path,
         "dimensions " + std::to_string(columns) + " x " + std::to_string(rows) + " = " +
             std::to_string(columns * rows) + " grid points exceed the budget of " + std::to_string(max_points) +
             " (~max_cells; about 4 bytes of heights per point and process, more once deformed)");
}

/// The geometry of a raster read from a file, checked before its heights are allocated.
void checkPlausibleGeometry(const char* function, const std::string& path, double origin_x, double origin_y,
                            double cell_size)
{
  if (!(cell_size >= kMinPlausibleCellSize && cell_size <= kMaxPlausibleCellSize))
    fail(function, path,
         "cell size " + std::to_string(cell_size) + " m is outside the plausible range [" +
             std::to_string(kMinPlausibleCellSize) + ", " + std::to_string(kMaxPlausibleCellSize) + "] m");
  if (!(std::abs(origin_x) <= kMaxPlausibleCoordinate && std::abs(origin_y) <= kMaxPlausibleCoordinate))
    fail(function, path,
         "origin (" + std::to_string(origin_x) + ", " + std::to_string(origin_y) +
             ") m is beyond the plausible +-1e8 m of a projected CRS");
}

/// Heights of a raster read from a file: none beyond the deepest trench or the highest peak.
void checkPlausibleHeights(const char* function, const std::string& path, const HeightRaster& raster)
{
  for (std::size_t k = 0; k < raster.heights.size(); ++k)
  {
    const float z = raster.heights[k];
    if (!std::isnan(z) && !(z >= kMinPlausibleHeight && z <= kMaxPlausibleHeight))
      fail(function, path,
           "height " + std::to_string(z) + " m at grid point (" + std::to_string(k % raster.columns) + ", " +
               std::to_string(k / raster.columns) + ") is outside the plausible range [" +
               std::to_string(kMinPlausibleHeight) + ", " + std::to_string(kMaxPlausibleHeight) + "] m");
  }
}

/// A raster read from a file must carry at least one height.
void rejectAllNoData(const char* function, const std::string& path, const HeightRaster& raster)
{
  if (raster.noDataCount() == raster.heights.size())
    fail(function, path, "every point is no-data");
}

/// Preconditions shared by the writers: consistent sizes, a usable georeference, and no
/// infinite heights (NaN is no-data).
void checkWritable(const char* function, const std::string& path, const HeightRaster& raster)
{
  checkDimensions(function, path, raster.columns, raster.rows);
  if (raster.heights.size() != raster.columns * raster.rows)
    fail(function, path,
         "raster has " + std::to_string(raster.heights.size()) +
             " heights, expected columns*rows = " + std::to_string(raster.columns * raster.rows));
  if (!std::isfinite(raster.origin_x) || !std::isfinite(raster.origin_y))
    fail(function, path, "raster origin is not finite");
  if (!(raster.cell_size > 0.0) || !std::isfinite(raster.cell_size))
    fail(function, path, "raster cell size must be finite and > 0");
  for (std::size_t k = 0; k < raster.heights.size(); ++k)
  {
    if (std::isinf(raster.heights[k]))
      fail(function, path,
           "height at point (" + std::to_string(k % raster.columns) + ", " + std::to_string(k / raster.columns) +
               ") is infinite");
  }
}

/// Preconditions of the class-raster writers: consistent sizes and a usable georeference.
void checkClassWritable(const char* function, const std::string& path, const ClassRaster& raster)
{
  checkDimensions(function, path, raster.columns, raster.rows);
  if (raster.values.size() != raster.columns * raster.rows)
    fail(function, path,
         "raster has " + std::to_string(raster.values.size()) +
             " values, expected columns*rows = " + std::to_string(raster.columns * raster.rows));
  if (!std::isfinite(raster.origin_x) || !std::isfinite(raster.origin_y))
    fail(function, path, "raster origin is not finite");
  if (!(raster.cell_size > 0.0) || !std::isfinite(raster.cell_size))
    fail(function, path, "raster cell size must be finite and > 0");
}

// ------------------------------------------------------------------------------------------
// ESRI ASCII grid
// ------------------------------------------------------------------------------------------

/// Whitespace-separated tokens of a file, read in chunks so that a large grid is never held
/// as text in memory.
class TokenReader
{
public:
  enum class Next
  {
    kToken,
    kEnd,
    kReadError,
    kTooLong
  };

  explicit TokenReader(std::FILE* file) : file_(file), buffer_(1 << 16) {}

  Next next(std::string& token)
  {
    // No number or header key is this long; a longer token means binary garbage, and the
    // cap keeps it from growing without bound.
    constexpr std::size_t kMaxToken = 64;
    token.clear();
    for (;;)
    {
      if (pos_ == length_ && !refill())
      {
        if (read_error_)
          return Next::kReadError;
        return token.empty() ? Next::kEnd : Next::kToken;
      }
      const char c = buffer_[pos_];
      if (c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f')
      {
        ++pos_;
        if (!token.empty())
          return Next::kToken;
        continue;
      }
      if (token.size() >= kMaxToken)
        return Next::kTooLong;
      token.push_back(c);
      ++pos_;
    }
  }

private:
  bool refill()
  {
    length_ = std::fread(buffer_.data(), 1, buffer_.size(), file_);
    pos_ = 0;
    if (length_ == 0)
      read_error_ = std::ferror(file_) != 0;
    return length_ > 0;
  }

  std::FILE* file_;
  std::vector<char> buffer_;
  std::size_t pos_ = 0;
  std::size_t length_ = 0;
  bool read_error_ = false;
};

bool parseInteger(const std::string& token, long long& value)
{
  errno = 0;
  char* end = nullptr;
  value = std::strtoll(token.c_str(), &end, 10);
  return end == token.c_str() + token.size() && errno != ERANGE;
}

bool parseFiniteDouble(const std::string& token, double& value)
{
  char* end = nullptr;
  value = std::strtod(token.c_str(), &end);
  return end == token.c_str() + token.size() && std::isfinite(value);
}

/// strtof rounds the decimal text straight to the nearest float; going through double
/// could round twice and break the bit-exact round trip.
bool parseFloat(const std::string& token, float& value)
{
  char* end = nullptr;
  value = std::strtof(token.c_str(), &end);
  return end == token.c_str() + token.size();
}

std::string lowercase(std::string s)
{
  for (char& c : s)
    if (c >= 'A' && c <= 'Z')
      c = static_cast<char>(c - 'A' + 'a');
  return s;
}

bool startsWithLetter(const std::string& token)
{
  const char c = token.empty() ? '\0' : token[0];
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
}

struct AsciiHeader
{
  std::optional<long long> ncols, nrows;
  std::optional<double> xllcorner, xllcenter, yllcorner, yllcenter, cellsize;
  std::optional<float> nodata;

  bool complete() const { return ncols && nrows && (xllcorner || xllcenter) && (yllcorner || yllcenter) && cellsize; }
};

const char* describe(TokenReader::Next status)
{
  return status == TokenReader::Next::kReadError ? "read error" : "token longer than 64 characters (binary file?)";
}
}  // namespace

std::size_t HeightRaster::noDataCount() const
{
  return static_cast<std::size_t>(std::count_if(heights.begin(), heights.end(), [](float h) { return std::isnan(h); }));
}

namespace
{
/// Reads the header's key/value pairs; leaves `token`/`status` at the first data token.
AsciiHeader readAsciiHeader(const char* fn, const std::string& path, TokenReader& reader, std::string& token,
                            TokenReader::Next& status)
{
  using Next = TokenReader::Next;
  AsciiHeader hdr;
  std::string value;
  status = reader.next(token);
  // The header ends at the first token that is not a header key; a data value never starts
  // with a letter except nan/inf, which are rejected below.
  while (status == Next::kToken && startsWithLetter(token))
  {
    const std::string key = lowercase(token);
    std::optional<long long>* int_slot = nullptr;
    std::optional<double>* double_slot = nullptr;
    std::optional<float>* float_slot = nullptr;
    if (key == "ncols")
      int_slot = &hdr.ncols;
    else if (key == "nrows")
      int_slot = &hdr.nrows;
    else if (key == "xllcorner")
      double_slot = &hdr.xllcorner;
    else if (key == "xllcenter")
      double_slot = &hdr.xllcenter;
    else if (key == "yllcorner")
      double_slot = &hdr.yllcorner;
    else if (key == "yllcenter")
      double_slot = &hdr.yllcenter;
    else if (key == "cellsize")
      double_slot = &hdr.cellsize;
    else if (key == "nodata_value")
      float_slot = &hdr.nodata;
    else if (hdr.complete())
      break;  // first data value; the data loop names it
    else
      fail(fn, path, "unknown header key " + quoted(token) + " (or a required key is missing)");

    if ((int_slot && *int_slot) || (double_slot && *double_slot) || (float_slot && *float_slot))
      fail(fn, path, "header key " + quoted(token) + " appears twice");
    const Next value_status = reader.next(value);
    if (value_status != Next::kToken)
      fail(fn, path, "header key " + quoted(token) + " has no value (truncated header)");
    bool ok = false;
    if (int_slot)
    {
      long long v = 0;
      ok = parseInteger(value, v);
      *int_slot = v;
    }
    else if (double_slot)
    {
      double v = 0.0;
      ok = parseFiniteDouble(value, v);
      *double_slot = v;
    }
    else
    {
      // NODATA_value is compared with the data as float, so it is parsed as float too.
      float v = 0.0f;
      ok = parseFloat(value, v) && std::isfinite(v);
      *float_slot = v;
    }
    if (!ok)
      fail(fn, path, "header key " + quoted(token) + " has a non-numeric or non-finite value " + quoted(value));
    status = reader.next(token);
  }
  if (status == Next::kReadError || status == Next::kTooLong)
    fail(fn, path, describe(status));
  return hdr;
}

/// Refuses a header with a key missing, given twice over (corner and centre) or out of range.
void checkAsciiHeader(const char* fn, const std::string& path, const AsciiHeader& hdr)
{
  if (!hdr.ncols)
    fail(fn, path, "missing header key 'ncols'");
  if (!hdr.nrows)
    fail(fn, path, "missing header key 'nrows'");
  if (!hdr.xllcorner && !hdr.xllcenter)
    fail(fn, path, "missing header key 'xllcorner' or 'xllcenter'");
  if (!hdr.yllcorner && !hdr.yllcenter)
    fail(fn, path, "missing header key 'yllcorner' or 'yllcenter'");
  if (!hdr.cellsize)
    fail(fn, path, "missing header key 'cellsize'");
  if (hdr.xllcorner && hdr.xllcenter)
    fail(fn, path, "both 'xllcorner' and 'xllcenter' given");
  if (hdr.yllcorner && hdr.yllcenter)
    fail(fn, path, "both 'yllcorner' and 'yllcenter' given");
  if (*hdr.ncols <= 0 || *hdr.nrows <= 0)
    fail(fn, path,
         "ncols and nrows must be > 0 (got " + std::to_string(*hdr.ncols) + " x " + std::to_string(*hdr.nrows) + ")");
  if (!(*hdr.cellsize > 0.0))
    fail(fn, path, "cellsize must be > 0 (got " + std::to_string(*hdr.cellsize) + ")");
}

/// Reads the values into `raster` (sized by the header), from `token` on; rows north first.
void readAsciiValues(const char* fn, const std::string& path, const AsciiHeader& hdr, TokenReader& reader,
                     std::string& token, TokenReader::Next status, HeightRaster& raster)
{
  using Next = TokenReader::Next;
  const std::uint64_t columns = raster.columns, rows = raster.rows, count = columns * rows;
  std::uint64_t n = 0;
  for (; status == Next::kToken; status = reader.next(token))
  {
    if (n == count)
      fail(fn, path, "more values than ncols*nrows = " + std::to_string(count) + " (wrong header?)");
    const std::uint64_t file_row = n / columns;
    const std::uint64_t column = n % columns;
    float v = 0.0f;
    if (!parseFloat(token, v))
      fail(fn, path,
           "non-numeric value " + quoted(token) + " at data row " + std::to_string(file_row + 1) + ", column " +
               std::to_string(column + 1));
    if (!std::isfinite(v))
      fail(fn, path,
           "value " + quoted(token) + " at data row " + std::to_string(file_row + 1) + ", column " +
               std::to_string(column + 1) + " is not finite (nan, inf or beyond float range; use NODATA_value)");
    // The first data row is the northern edge.
    const std::uint64_t j = rows - 1 - file_row;
    raster.heights[static_cast<std::size_t>(j * columns + column)] = (hdr.nodata && v == *hdr.nodata) ? kNoData : v;
    ++n;
  }
  if (status != Next::kEnd)
    fail(fn, path, describe(status));
  if (n < count)
    fail(fn, path, "truncated: found " + std::to_string(n) + " of " + std::to_string(count) + " values");
}
}  // namespace

HeightRaster readAsciiGrid(const std::string& path, const DemLimits& limits)
{
  const char* const fn = "readAsciiGrid";
  const std::uint64_t file_bytes = checkInputFile(fn, path);
  FilePtr file = openForRead(fn, path);
  TokenReader reader(file.get());

  std::string token;
  TokenReader::Next status = TokenReader::Next::kEnd;
  const AsciiHeader hdr = readAsciiHeader(fn, path, reader, token, status);
  checkAsciiHeader(fn, path, hdr);

  const auto columns = static_cast<std::uint64_t>(*hdr.ncols);
  const auto rows = static_cast<std::uint64_t>(*hdr.nrows);
  checkDimensions(fn, path, columns, rows, limits.max_points);
  const std::uint64_t count = columns * rows;
  // Each value takes at least one character and one separator; checking this before the
  // allocation keeps a corrupt header in a small file from reserving gigabytes.
  if (2 * count - 1 > file_bytes)
    fail(fn, path,
         "truncated: header declares " + std::to_string(count) + " values but the file has only " +
             std::to_string(file_bytes) + " bytes");

  HeightRaster raster;
  raster.columns = static_cast<std::size_t>(columns);
  raster.rows = static_cast<std::size_t>(rows);
  raster.cell_size = *hdr.cellsize;
  // A corner names the outer edge of the south-west cell; grid points are cell centres.
  raster.origin_x = hdr.xllcorner ? *hdr.xllcorner + 0.5 * raster.cell_size : *hdr.xllcenter;
  raster.origin_y = hdr.yllcorner ? *hdr.yllcorner + 0.5 * raster.cell_size : *hdr.yllcenter;
  checkPlausibleGeometry(fn, path, raster.origin_x, raster.origin_y, raster.cell_size);
  raster.heights.assign(static_cast<std::size_t>(count), kNoData);

  readAsciiValues(fn, path, hdr, reader, token, status, raster);
  rejectAllNoData(fn, path, raster);
  checkPlausibleHeights(fn, path, raster);
  return raster;
}

void writeAsciiGrid(const HeightRaster& raster, const std::string& path)
{
  const char* const fn = "writeAsciiGrid";
  constexpr float kFileNoData = -9999.0f;
  checkWritable(fn, path, raster);
  for (std::size_t k = 0; k < raster.heights.size(); ++k)
  {
    if (raster.heights[k] == kFileNoData)
      fail(fn, path,
           "height at point (" + std::to_string(k % raster.columns) + ", " + std::to_string(k / raster.columns) +
               ") equals NODATA_value -9999 and would read back as no-data");
  }
  FilePtr f = openForWrite(fn, path);
  // %.17g round-trips any double, %.9g any float.
  std::fprintf(f.get(), "ncols %zu\nnrows %zu\nxllcenter %.17g\nyllcenter %.17g\ncellsize %.17g\nNODATA_value -9999\n",
               raster.columns, raster.rows, raster.origin_x, raster.origin_y, raster.cell_size);
  for (std::size_t file_row = 0; file_row < raster.rows; ++file_row)
  {
    const float* row = &raster.heights[(raster.rows - 1 - file_row) * raster.columns];
    for (std::size_t i = 0; i < raster.columns; ++i)
    {
      if (i > 0)
        std::fputc(' ', f.get());
      if (std::isnan(row[i]))
        std::fputs("-9999", f.get());
      else
        std::fprintf(f.get(), "%.9g", static_cast<double>(row[i]));
    }
    std::fputc('\n', f.get());
  }
  closeWritten(fn, path, f);
}

// ------------------------------------------------------------------------------------------
// 16-bit PNG (libpng)
// ------------------------------------------------------------------------------------------
namespace
{
/// libpng reports errors by longjmp; the handler keeps the message for the DemError.
struct PngErrorState
{
  std::jmp_buf jump;
  char message[256];
};

[[noreturn]] void pngError(png_structp png, png_const_charp message)
{
  auto* state = static_cast<PngErrorState*>(png_get_error_ptr(png));
  std::snprintf(state->message, sizeof state->message, "%s", message);
  std::longjmp(state->jump, 1);
}

/// Warnings (e.g. a bad CRC in an ancillary chunk) do not affect the heights.
void pngWarning(png_structp, png_const_charp)
{
}

struct PngReadHandle
{
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~PngReadHandle() { png_destroy_read_struct(&png, &info, nullptr); }
};

struct PngWriteHandle
{
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~PngWriteHandle() { png_destroy_write_struct(&png, &info); }
};

struct PngHeader
{
  png_uint_32 width = 0, height = 0;
  int bit_depth = 0, colour_type = 0;
  png_size_t row_bytes = 0;
};

// The functions calling setjmp hold only trivially destructible locals and change no local
// after setjmp, so the longjmp skips no destructor and reads no clobbered variable.

bool pngReadHeader(PngReadHandle& h, PngErrorState& err, std::FILE* file, PngHeader& out)
{
  if (setjmp(err.jump))
    return false;
  png_init_io(h.png, file);
  // Our own point limit and file-size check replace libpng's default 10^6 pixel width limit.
  png_set_user_limits(h.png, PNG_UINT_31_MAX, PNG_UINT_31_MAX);
  png_read_info(h.png, h.info);
  int interlace = 0;
  png_get_IHDR(h.png, h.info, &out.width, &out.height, &out.bit_depth, &out.colour_type, &interlace, nullptr, nullptr);
  png_set_interlace_handling(h.png);
  png_read_update_info(h.png, h.info);
  out.row_bytes = png_get_rowbytes(h.png, h.info);
  return true;
}

bool pngReadRows(PngReadHandle& h, PngErrorState& err, png_bytepp rows)
{
  if (setjmp(err.jump))
    return false;
  png_read_image(h.png, rows);
  // Reading up to IEND detects a file cut after the image data.
  png_read_end(h.png, nullptr);
  return true;
}

bool pngWriteAll(PngWriteHandle& h, PngErrorState& err, std::FILE* file, png_uint_32 width, png_uint_32 height,
                 int bit_depth, png_bytepp rows)
{
  if (setjmp(err.jump))
    return false;
  png_init_io(h.png, file);
  png_set_IHDR(h.png, h.info, width, height, bit_depth, PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(h.png, h.info);
  png_write_image(h.png, rows);
  png_write_end(h.png, nullptr);
  return true;
}

const char* pngColourName(int colour_type)
{
  switch (colour_type)
  {
    case PNG_COLOR_TYPE_GRAY:
      return "greyscale";
    case PNG_COLOR_TYPE_GRAY_ALPHA:
      return "greyscale+alpha";
    case PNG_COLOR_TYPE_RGB:
      return "RGB";
    case PNG_COLOR_TYPE_RGB_ALPHA:
      return "RGBA";
    case PNG_COLOR_TYPE_PALETTE:
      return "palette";
    default:
      return "unknown";
  }
}

void checkGeoref(const char* function, const std::string& path, const Png16Georef& g)
{
  if (!std::isfinite(g.origin_x) || !std::isfinite(g.origin_y) || !std::isfinite(g.z_offset))
    fail(function, path, "georef origin and z_offset must be finite");
  if (!(g.cell_size > 0.0) || !std::isfinite(g.cell_size))
    fail(function, path, "georef cell_size must be finite and > 0");
  if (!(g.z_scale > 0.0) || !std::isfinite(g.z_scale))
    fail(function, path, "georef z_scale must be finite and > 0");
}

/// Writes greyscale rows (north first, big-endian samples for 16 bits) as a PNG file; a
/// failed write removes the partial file.
void writePngFile(const char* fn, const std::string& path, std::size_t columns, std::size_t rows, int bit_depth,
                  std::vector<png_byte>& pixels)
{
  const std::size_t row_bytes = columns * static_cast<std::size_t>(bit_depth / 8);
  std::vector<png_bytep> row_pointers(rows);
  for (std::size_t r = 0; r < rows; ++r)
    row_pointers[r] = &pixels[r * row_bytes];

  FilePtr file = openForWrite(fn, path);
  PngErrorState err{};
  bool ok = false;
  {
    PngWriteHandle h;
    h.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &err, pngError, pngWarning);
    if (h.png != nullptr)
      h.info = png_create_info_struct(h.png);
    if (h.png != nullptr && h.info != nullptr)
      ok = pngWriteAll(h, err, file.get(), static_cast<png_uint_32>(columns), static_cast<png_uint_32>(rows), bit_depth,
                       row_pointers.data());
    else
      std::snprintf(err.message, sizeof err.message, "%s", "cannot allocate libpng state");
  }
  if (!ok)
  {
    file.reset();
    std::remove(path.c_str());
    fail(fn, path, std::string("PNG write failed (libpng: ") + err.message + ")");
  }
  closeWritten(fn, path, file);
}
}  // namespace

HeightRaster readPng16(const std::string& path, const Png16Georef& georef, const DemLimits& limits)
{
  const char* const fn = "readPng16";
  checkGeoref(fn, path, georef);
  checkPlausibleGeometry(fn, path, georef.origin_x, georef.origin_y, georef.cell_size);
  const std::uint64_t file_bytes = checkInputFile(fn, path);
  FilePtr file = openForRead(fn, path);

  png_byte signature[8] = {};
  if (std::fread(signature, 1, sizeof signature, file.get()) != sizeof signature ||
      png_sig_cmp(signature, 0, sizeof signature) != 0)
    fail(fn, path, "not a PNG file (bad signature or truncated)");
  std::rewind(file.get());

  PngErrorState err{};
  PngReadHandle h;
  h.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &err, pngError, pngWarning);
  if (h.png != nullptr)
    h.info = png_create_info_struct(h.png);
  if (h.png == nullptr || h.info == nullptr)
    fail(fn, path, "libpng could not allocate its state");

  PngHeader hdr;
  if (!pngReadHeader(h, err, file.get(), hdr))
    fail(fn, path, std::string("corrupt or truncated PNG header (libpng: ") + err.message + ")");
  if (hdr.colour_type != PNG_COLOR_TYPE_GRAY)
    fail(fn, path,
         std::string("colour type ") + pngColourName(hdr.colour_type) + " not supported (need 16-bit greyscale)");
  if (hdr.bit_depth != 16)
    fail(fn, path, "bit depth " + std::to_string(hdr.bit_depth) + " not supported (need 16-bit greyscale)");
  checkDimensions(fn, path, hdr.width, hdr.height, limits.max_points);
  const std::uint64_t width = hdr.width;
  const std::uint64_t height = hdr.height;
  if (hdr.row_bytes != 2 * width)
    fail(fn, path, "unexpected row size from libpng");
  // Deflate compresses at most about 1032:1, so a header claiming far more pixel data than
  // the file can hold is corrupt; rejecting it here avoids a pointless huge allocation.
  constexpr std::uint64_t kMaxDeflateRatio = 1100;
  if (height * (2 * width + 1) > kMaxDeflateRatio * file_bytes + 65536)
    fail(fn, path,
         "truncated or corrupt: a " + std::to_string(width) + " x " + std::to_string(height) + " image cannot fit in " +
             std::to_string(file_bytes) + " bytes");

  std::vector<png_byte> pixels(static_cast<std::size_t>(height * 2 * width));
  std::vector<png_bytep> row_pointers(static_cast<std::size_t>(height));
  for (std::size_t r = 0; r < row_pointers.size(); ++r)
    row_pointers[r] = &pixels[r * 2 * width];
  if (!pngReadRows(h, err, row_pointers.data()))
    fail(fn, path, std::string("truncated or corrupt PNG image data (libpng: ") + err.message + ")");

  HeightRaster raster;
  raster.origin_x = georef.origin_x;
  raster.origin_y = georef.origin_y;
  raster.cell_size = georef.cell_size;
  raster.columns = static_cast<std::size_t>(width);
  raster.rows = static_cast<std::size_t>(height);
  raster.heights.resize(raster.columns * raster.rows);
  for (std::size_t r = 0; r < raster.rows; ++r)
  {
    // Pixel row 0 is the northern edge; PNG samples are big-endian.
    const png_byte* src = row_pointers[r];
    float* dst = &raster.heights[(raster.rows - 1 - r) * raster.columns];
    for (std::size_t i = 0; i < raster.columns; ++i)
    {
      const unsigned value = (static_cast<unsigned>(src[2 * i]) << 8) | src[2 * i + 1];
      dst[i] = static_cast<float>(georef.z_offset + georef.z_scale * value / 65535.0);
    }
  }
  checkPlausibleHeights(fn, path, raster);
  return raster;
}

void writePng16(const HeightRaster& raster, const std::string& path, const Png16Georef& georef)
{
  const char* const fn = "writePng16";
  checkGeoref(fn, path, georef);
  checkWritable(fn, path, raster);
  if (raster.columns > PNG_UINT_31_MAX || raster.rows > PNG_UINT_31_MAX)
    fail(fn, path, "too many columns or rows for PNG");
  // The PNG keeps no georeference; a mismatch would silently move the terrain on re-read.
  const double tolerance = 1e-9 * georef.cell_size;
  if (std::abs(raster.cell_size - georef.cell_size) > tolerance ||
      std::abs(raster.origin_x - georef.origin_x) > tolerance ||
      std::abs(raster.origin_y - georef.origin_y) > tolerance)
    fail(fn, path, "georef origin/cell_size do not match the raster's");

  std::vector<png_byte> pixels(raster.heights.size() * 2);
  for (std::size_t j = 0; j < raster.rows; ++j)
  {
    png_byte* dst = &pixels[(raster.rows - 1 - j) * raster.columns * 2];  // north row first
    for (std::size_t i = 0; i < raster.columns; ++i)
    {
      const float z = raster.heights[j * raster.columns + i];
      // Built only on failure: a string per pixel would dominate the cost of a large raster.
      const auto where = [&] { return "(" + std::to_string(i) + ", " + std::to_string(j) + ")"; };
      if (std::isnan(z))
        fail(fn, path, "no-data at point " + where() + " cannot be stored in a PNG; fill it first");
      const double q = (static_cast<double>(z) - georef.z_offset) / georef.z_scale * 65535.0;
      if (!(q >= -0.5 && q < 65535.5))
        fail(fn, path,
             "height " + std::to_string(z) + " m at point " + where() + " is outside the PNG range [z_offset, " +
                 "z_offset + z_scale]");
      const auto value = static_cast<unsigned>(std::min(65535.0, std::max(0.0, std::round(q))));
      dst[2 * i] = static_cast<png_byte>(value >> 8);
      dst[2 * i + 1] = static_cast<png_byte>(value & 0xffu);
    }
  }
  writePngFile(fn, path, raster.columns, raster.rows, 16, pixels);
}

void writeClassPng8(const ClassRaster& raster, const std::string& path)
{
  const char* const fn = "writeClassPng8";
  checkClassWritable(fn, path, raster);
  if (raster.columns > PNG_UINT_31_MAX || raster.rows > PNG_UINT_31_MAX)
    fail(fn, path, "too many columns or rows for PNG");
  std::vector<png_byte> pixels(raster.values.size());
  for (std::size_t j = 0; j < raster.rows; ++j)  // north row first
    std::copy_n(&raster.values[j * raster.columns], raster.columns, &pixels[(raster.rows - 1 - j) * raster.columns]);
  writePngFile(fn, path, raster.columns, raster.rows, 8, pixels);
}

// ------------------------------------------------------------------------------------------
// PNG georeference sidecar (YAML)
// ------------------------------------------------------------------------------------------
void writePng16Georef(const Png16Georef& georef, const std::string& path, const std::string& image_name)
{
  const char* const fn = "writePng16Georef";
  checkGeoref(fn, path, georef);
  FilePtr f = openForWrite(fn, path);
  std::fprintf(f.get(),
               "# Georeference of the 16-bit greyscale PNG heightmap '%s' (avsp_terrain Png16Georef).\n"
               "# Pixel row 0 is the north edge; pixel (c, r) of an image of R rows is grid point\n"
               "# (origin_x + c * cell_size, origin_y + (R - 1 - r) * cell_size); pixel value v is the\n"
               "# height z_offset + z_scale * v / 65535. All in metres, map frame.\n"
               "origin_x: %.17g\norigin_y: %.17g\ncell_size: %.17g\nz_offset: %.17g\nz_scale: %.17g\n",
               image_name.c_str(), georef.origin_x, georef.origin_y, georef.cell_size, georef.z_offset, georef.z_scale);
  closeWritten(fn, path, f);
}

Png16Georef readPng16Georef(const std::string& path)
{
  const char* const fn = "readPng16Georef";
  checkInputFile(fn, path);
  Png16Georef g;
  try
  {
    const YamlSection<DemError> root = loadYamlFile<DemError>(path);
    root.allowOnly({ "cell_size", "origin_x", "origin_y", "z_offset", "z_scale" });
    g.origin_x = root.number("origin_x");
    g.origin_y = root.number("origin_y");
    g.cell_size = root.positive("cell_size");
    g.z_offset = root.number("z_offset");
    g.z_scale = root.positive("z_scale");
  }
  catch (const YAML::Exception& e)
  {
    fail(fn, path, "line " + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  return g;
}

// ------------------------------------------------------------------------------------------
// GeoTIFF (GDAL)
// ------------------------------------------------------------------------------------------
namespace
{
void registerGdalDrivers()
{
  static std::once_flag once;
  std::call_once(once, [] { GDALAllRegister(); });
}

/// Keeps GDAL from printing to stderr while we work; its message goes into the DemError.
/// The handler stack is per thread.
class GdalQuietErrors
{
public:
  GdalQuietErrors()
  {
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErrorReset();
  }
  ~GdalQuietErrors() { CPLPopErrorHandler(); }
  GdalQuietErrors(const GdalQuietErrors&) = delete;
  GdalQuietErrors& operator=(const GdalQuietErrors&) = delete;

  static std::string lastMessage()
  {
    const char* m = CPLGetLastErrorMsg();
    return std::string("GDAL: ") + ((m != nullptr && *m != '\0') ? m : "no details");
  }
};

struct GdalCloser
{
  void operator()(std::remove_pointer_t<GDALDatasetH>* ds) const { GDALClose(ds); }
};
using DatasetPtr = std::unique_ptr<std::remove_pointer_t<GDALDatasetH>, GdalCloser>;

bool isMetreName(const std::string& unit)
{
  const std::string u = lowercase(unit);
  return u == "m" || u == "metre" || u == "meter" || u == "metres" || u == "meters";
}
}  // namespace

namespace
{
/// Reads the geotransform into `gt`; refuses one that is missing, rotated, not north-up or
/// not square, a CRS in degrees or feet, and heights not in metres.
void readNorthUpMetres(const char* fn, const std::string& path, GDALDatasetH ds, GDALRasterBandH band, double gt[6])
{
  // Without a geotransform GDAL returns a made-up identity one; never use it.
  if (GDALGetGeoTransform(ds, gt) != CE_None)
    fail(fn, path, "no geotransform (file is not georeferenced)");
  for (int k = 0; k < 6; ++k)
    if (!std::isfinite(gt[k]))
      fail(fn, path, "geotransform is not finite");
  if (gt[2] != 0.0 || gt[4] != 0.0)
    fail(fn, path, "rotated or sheared geotransform not supported (north-up only)");
  if (!(gt[1] > 0.0) || !(gt[5] < 0.0))
    fail(fn, path,
         "not north-up: pixel size (" + std::to_string(gt[1]) + ", " + std::to_string(gt[5]) +
             ") must have x > 0 and y < 0");
  if (std::abs(gt[1] + gt[5]) > 1e-9 * gt[1])
    fail(fn, path, "non-square pixels (" + std::to_string(gt[1]) + " x " + std::to_string(-gt[5]) + ")");

  // Cell sizes in degrees or feet would silently scale the terrain.
  if (OGRSpatialReferenceH srs = GDALGetSpatialRef(ds))
  {
    if (OSRIsGeographic(srs))
      fail(fn, path, "geographic CRS (pixel size in degrees); reproject to a projected CRS in metres");
    char* unit_name = nullptr;
    const double metres_per_unit = OSRGetLinearUnits(srs, &unit_name);
    if (std::abs(metres_per_unit - 1.0) > 1e-12)
      fail(fn, path, std::string("horizontal CRS unit '") + (unit_name ? unit_name : "?") + "' is not metres");
  }
  const char* unit = GDALGetRasterUnitType(band);
  if (unit != nullptr && *unit != '\0' && !isMetreName(unit))
    fail(fn, path, std::string("height unit '") + unit + "' is not metres");
}

/// How a band's raw values become heights.
struct BandCoding
{
  int has_nodata = 0;
  double nodata = 0.0;
  double scale = 1.0;
  double offset = 0.0;
};

BandCoding readBandCoding(const char* fn, const std::string& path, GDALRasterBandH band)
{
  BandCoding coding;
  coding.nodata = GDALGetRasterNoDataValue(band, &coding.has_nodata);
  int has_scale = 0, has_offset = 0;
  const double scale_raw = GDALGetRasterScale(band, &has_scale);
  const double offset_raw = GDALGetRasterOffset(band, &has_offset);
  // Absent scale/offset means raw values are heights (identity), not a guessed default.
  coding.scale = has_scale ? scale_raw : 1.0;
  coding.offset = has_offset ? offset_raw : 0.0;
  if (!std::isfinite(coding.scale) || !std::isfinite(coding.offset) || coding.scale == 0.0)
    fail(fn, path, "band scale/offset is not usable");
  return coding;
}

/// Reads the band's heights into `raster` (sized and placed), row 0 south.
void readBandRows(const char* fn, const std::string& path, GDALRasterBandH band, GDALDataType type,
                  const BandCoding& coding, HeightRaster& raster)
{
  const int width = static_cast<int>(raster.columns);
  const int height = static_cast<int>(raster.rows);
  // Memory: the heights are read row by row straight into the raster (flipped to row 0
  // south), so the file's data is held once. GDAL keeps every block it reads in its block
  // cache (by default 5 % of RAM, more than a site-size raster on a large machine), which
  // would hold the whole file a second time; the cache is therefore dropped after each row
  // of blocks. Float32, Int16 and UInt16 pixels are exact as float, so they are read as
  // Float32 in place; Float64 goes through a one-row double buffer so that its nodata
  // comparison and float-range check see the exact file value.
  int block_x = 0, block_y = 0;
  GDALGetBlockSize(band, &block_x, &block_y);
  if (block_y < 1)
    block_y = 1;
  const bool read_double = type == GDT_Float64;
  std::vector<double> line(read_double ? raster.columns : 0);
  for (int r = 0; r < height; ++r)
  {
    float* dst = &raster.heights[(raster.rows - 1 - static_cast<std::size_t>(r)) * raster.columns];
    void* buffer = read_double ? static_cast<void*>(line.data()) : static_cast<void*>(dst);
    if (GDALRasterIO(band, GF_Read, 0, r, width, 1, buffer, width, 1, read_double ? GDT_Float64 : GDT_Float32, 0, 0) !=
        CE_None)
      fail(fn, path,
           "cannot read pixel row " + std::to_string(r) + ", truncated or corrupt file (" +
               GdalQuietErrors::lastMessage() + ")");
    if ((r + 1) % block_y == 0 || r + 1 == height)
      GDALFlushRasterCache(band);  // read-only: releases the cached blocks, writes nothing
    for (std::size_t c = 0; c < raster.columns; ++c)
    {
      const double raw = read_double ? line[c] : static_cast<double>(dst[c]);
      if (std::isnan(raw) || (coding.has_nodata && raw == coding.nodata))
      {
        dst[c] = kNoData;
        continue;
      }
      // Without scale/offset the raw value is the height; applying 0 + 1 * raw would turn
      // -0 into +0 and break the bit-exact round trip.
      const double z = (coding.scale == 1.0 && coding.offset == 0.0) ? raw : coding.offset + coding.scale * raw;
      if (!(std::abs(z) <= static_cast<double>(FLT_MAX)))
        fail(fn, path,
             "value at pixel (" + std::to_string(c) + ", " + std::to_string(r) + ") is infinite or beyond float range");
      dst[c] = static_cast<float>(z);
    }
  }
}
}  // namespace

HeightRaster readGeoTiff(const std::string& path, const DemLimits& limits)
{
  const char* const fn = "readGeoTiff";
  // GDAL virtual paths (/vsizip/...) have no local file to check.
  if (path.rfind("/vsi", 0) != 0)
  {
    checkInputFile(fn, path);
    openForRead(fn, path);  // names an unreadable file plainly
  }
  registerGdalDrivers();
  GdalQuietErrors quiet;
  const char* const drivers[] = { "GTiff", nullptr };
  DatasetPtr ds(
      GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY | GDAL_OF_VERBOSE_ERROR, drivers, nullptr, nullptr));
  if (!ds)
    fail(fn, path, "not a readable GeoTIFF: not a TIFF, truncated or corrupt (" + GdalQuietErrors::lastMessage() + ")");
  if (GDALGetRasterCount(ds.get()) < 1)
    fail(fn, path, "file has no raster band");
  const int width = GDALGetRasterXSize(ds.get());
  const int height = GDALGetRasterYSize(ds.get());
  if (width <= 0 || height <= 0)
    fail(fn, path, "zero dimensions");
  checkDimensions(fn, path, static_cast<std::uint64_t>(width), static_cast<std::uint64_t>(height), limits.max_points);

  GDALRasterBandH band = GDALGetRasterBand(ds.get(), 1);
  const GDALDataType type = GDALGetRasterDataType(band);
  if (type != GDT_Float32 && type != GDT_Float64 && type != GDT_Int16 && type != GDT_UInt16)
    fail(fn, path,
         std::string("band data type ") + GDALGetDataTypeName(type) +
             " not supported (need Float32, Float64, Int16 or UInt16)");

  double gt[6] = {};
  readNorthUpMetres(fn, path, ds.get(), band, gt);
  const BandCoding coding = readBandCoding(fn, path, band);

  HeightRaster raster;
  raster.columns = static_cast<std::size_t>(width);
  raster.rows = static_cast<std::size_t>(height);
  raster.cell_size = gt[1];
  // Pixel (c, r) covers [gt0 + c gt1, gt0 + (c+1) gt1] x [gt3 + (r+1) gt5, gt3 + r gt5]; the
  // grid point is its centre, and the last pixel row is the southern one.
  raster.origin_x = gt[0] + 0.5 * gt[1];
  raster.origin_y = gt[3] + (height - 0.5) * gt[5];
  checkPlausibleGeometry(fn, path, raster.origin_x, raster.origin_y, raster.cell_size);
  raster.heights.resize(raster.columns * raster.rows);
  readBandRows(fn, path, band, type, coding, raster);
  rejectAllNoData(fn, path, raster);
  checkPlausibleHeights(fn, path, raster);
  return raster;
}

namespace
{
/**
 * Writes a one-band north-up GeoTIFF whose grid points are the pixel centres; `row(r)`
 * returns file row r (north first) in `type`. Height bands get unit metre and nodata NaN.
 * A failed write removes the partial file.
 */
template <class RowSource>
void writeGeoTiffBand(const char* fn, const std::string& path, std::size_t columns, std::size_t rows, double origin_x,
                      double origin_y, double cell, GDALDataType type, bool heights, const RowSource& row)
{
  if (columns > static_cast<std::size_t>(INT_MAX) || rows > static_cast<std::size_t>(INT_MAX))
    fail(fn, path, "too many columns or rows for GDAL");
  const int width = static_cast<int>(columns);
  const int height = static_cast<int>(rows);
  registerGdalDrivers();
  GdalQuietErrors quiet;
  GDALDriverH driver = GDALGetDriverByName("GTiff");
  if (driver == nullptr)
    fail(fn, path, "GDAL has no GTiff driver");
  DatasetPtr ds(GDALCreate(driver, path.c_str(), width, height, 1, type, nullptr));
  if (!ds)
    fail(fn, path, "cannot create file (" + GdalQuietErrors::lastMessage() + ")");

  bool ok = true;
  // Grid points are pixel centres, so the pixel edges lie half a cell outside them.
  double gt[6] = { origin_x - 0.5 * cell, cell, 0.0, origin_y + (static_cast<double>(rows) - 0.5) * cell, 0.0, -cell };
  ok = ok && GDALSetGeoTransform(ds.get(), gt) == CE_None;
  GDALRasterBandH band = GDALGetRasterBand(ds.get(), 1);
  if (heights)
  {
    ok = ok && GDALSetRasterNoDataValue(band, std::numeric_limits<double>::quiet_NaN()) == CE_None;
    ok = ok && GDALSetRasterUnitType(band, "metre") == CE_None;
  }
  for (int r = 0; ok && r < height; ++r)
    ok = GDALRasterIO(band, GF_Write, 0, r, width, 1, const_cast<void*>(row(static_cast<std::size_t>(r))), width, 1,
                      type, 0, 0) == CE_None;
  if (ok)
  {
    // Closing flushes; GDAL 3.6 reports a failed flush only through the error state.
    CPLErrorReset();
    ds.reset();
    ok = CPLGetLastErrorType() != CE_Failure && CPLGetLastErrorType() != CE_Fatal;
  }
  if (!ok)
  {
    const std::string why = GdalQuietErrors::lastMessage();
    ds.reset();
    std::remove(path.c_str());
    fail(fn, path, "write failed (" + why + ")");
  }
}
}  // namespace

void writeGeoTiff(const HeightRaster& raster, const std::string& path)
{
  const char* const fn = "writeGeoTiff";
  checkWritable(fn, path, raster);
  writeGeoTiffBand(fn, path, raster.columns, raster.rows, raster.origin_x, raster.origin_y, raster.cell_size,
                   GDT_Float32, true, [&](std::size_t file_row) -> const void* {
                     return &raster.heights[(raster.rows - 1 - file_row) * raster.columns];
                   });
}

void writeClassGeoTiff(const ClassRaster& raster, const std::string& path)
{
  const char* const fn = "writeClassGeoTiff";
  checkClassWritable(fn, path, raster);
  writeGeoTiffBand(fn, path, raster.columns, raster.rows, raster.origin_x, raster.origin_y, raster.cell_size, GDT_Byte,
                   false, [&](std::size_t file_row) -> const void* {
                     return &raster.values[(raster.rows - 1 - file_row) * raster.columns];
                   });
}

// ------------------------------------------------------------------------------------------
// No-data filling
// ------------------------------------------------------------------------------------------
std::size_t fillNoData(HeightRaster& raster, const std::string& source)
{
  const std::size_t n = raster.heights.size();
  if (raster.columns == 0 || raster.rows == 0 || n != raster.columns * raster.rows || n > kMaxPoints)
    throw DemError("fillNoData: '" + source + "': raster has " + std::to_string(n) + " heights for " +
                   std::to_string(raster.columns) + " x " + std::to_string(raster.rows) + " points");
  // 32-bit indices halve the queue for large rasters; kMaxPoints guarantees they fit.
  // Only valid points next to a no-data point are seeded: a valid point whose four
  // neighbours are all valid would visit nothing, so leaving it out changes neither the
  // result nor the order of the visits, and the queue holds the voids and their rims instead
  // of the whole raster (a 218 M-point site would otherwise need 872 MB for it).
  const std::size_t cols = raster.columns;
  const std::size_t rows = raster.rows;
  const auto missing = [&](std::size_t k) { return std::isnan(raster.heights[k]); };
  std::vector<std::uint32_t> queue;
  std::vector<bool> known(n, false);
  bool any_valid = false;
  for (std::size_t j = 0, k = 0; j < rows; ++j)
  {
    for (std::size_t i = 0; i < cols; ++i, ++k)
    {
      if (missing(k))
        continue;
      known[k] = true;
      any_valid = true;
      if ((i > 0 && missing(k - 1)) || (i + 1 < cols && missing(k + 1)) || (j > 0 && missing(k - cols)) ||
          (j + 1 < rows && missing(k + cols)))
        queue.push_back(static_cast<std::uint32_t>(k));
    }
  }
  if (!any_valid)
    throw DemError("fillNoData: '" + source + "': every point is no-data, nothing to fill from");

  // Multi-source breadth-first search: each no-data point takes the height carried by the
  // first wave to reach it, i.e. from a valid point at the fewest 4-neighbour steps.
  std::size_t filled = 0;
  for (std::size_t head = 0; head < queue.size(); ++head)
  {
    const std::size_t k = queue[head];
    const std::size_t i = k % cols;
    const std::size_t j = k / cols;
    auto visit = [&](std::size_t nk) {
      if (!known[nk])
      {
        known[nk] = true;
        raster.heights[nk] = raster.heights[k];
        queue.push_back(static_cast<std::uint32_t>(nk));
        ++filled;
      }
    };
    if (i > 0)
      visit(k - 1);
    if (i + 1 < cols)
      visit(k + 1);
    if (j > 0)
      visit(k - cols);
    if (j + 1 < rows)
      visit(k + cols);
  }
  return filled;
}

}  // namespace terrain
}  // namespace avsp
