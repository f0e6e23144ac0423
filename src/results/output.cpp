#include "avsp/results/output.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <cstdint>
#include <fstream>
#include <limits>
#include <stdexcept>

namespace avsp
{
namespace results
{
Json::Json(bool b) : kind_(Kind::kBool), bool_(b)
{
}

Json::Json(double number)
{
  if (std::isfinite(number))
  {
    kind_ = Kind::kNumber;
    number_ = number;
  }
}

Json::Json(const char* text) : kind_(Kind::kString), string_(text ? text : "")
{
}

Json::Json(const std::string& text) : kind_(Kind::kString), string_(text)
{
}

Json Json::array()
{
  Json j;
  j.kind_ = Kind::kArray;
  return j;
}

Json Json::object()
{
  Json j;
  j.kind_ = Kind::kObject;
  return j;
}

Json& Json::push(Json value)
{
  if (kind_ != Kind::kArray)
    throw std::logic_error("Json::push on a value that is not an array");
  items_.push_back(std::move(value));
  return *this;
}

Json& Json::set(const std::string& key, Json value)
{
  if (kind_ != Kind::kObject)
    throw std::logic_error("Json::set('" + key + "') on a value that is not an object");
  for (auto& m : members_)
    if (m.first == key)
    {
      m.second = std::move(value);
      return *this;
    }
  members_.emplace_back(key, std::move(value));
  return *this;
}

std::string jsonQuote(const std::string& text)
{
  std::string out = "\"";
  for (const char ch : text)
  {
    const auto c = static_cast<unsigned char>(ch);
    switch (c)
    {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (c < 0x20)
        {
          char buffer[8];
          std::snprintf(buffer, sizeof buffer, "\\u%04x", c);
          out += buffer;
        }
        else
          out += ch;  // UTF-8 passes through unchanged
    }
  }
  return out + "\"";
}

std::string Json::dump(int indent) const
{
  std::string out;
  write(out, indent, 0);
  return out + "\n";
}

void Json::write(std::string& out, int indent, int level) const
{
  const std::string pad(static_cast<std::size_t>(indent * (level + 1)), ' ');
  const std::string end_pad(static_cast<std::size_t>(indent * level), ' ');
  switch (kind_)
  {
    case Kind::kNull:
      out += "null";
      break;
    case Kind::kBool:
      out += bool_ ? "true" : "false";
      break;
    case Kind::kNumber:
    {
      char buffer[32];
      std::snprintf(buffer, sizeof buffer, "%.10g", number_);
      out += buffer;
      break;
    }
    case Kind::kString:
      out += jsonQuote(string_);
      break;
    case Kind::kArray:
      if (items_.empty())
      {
        out += "[]";
        break;
      }
      out += "[\n";
      for (std::size_t k = 0; k < items_.size(); ++k)
      {
        out += pad;
        items_[k].write(out, indent, level + 1);
        out += k + 1 < items_.size() ? ",\n" : "\n";
      }
      out += end_pad + "]";
      break;
    case Kind::kObject:
      if (members_.empty())
      {
        out += "{}";
        break;
      }
      out += "{\n";
      for (std::size_t k = 0; k < members_.size(); ++k)
      {
        out += pad + jsonQuote(members_[k].first) + ": ";
        members_[k].second.write(out, indent, level + 1);
        out += k + 1 < members_.size() ? ",\n" : "\n";
      }
      out += end_pad + "}";
      break;
  }
}

namespace
{
/// An output file that throws naming itself on any failure.
class OutFile
{
public:
  explicit OutFile(const std::string& path) : path_(path), out_(path, std::ios::binary | std::ios::trunc)
  {
    if (!out_)
      throw std::runtime_error("cannot write " + path_ + ": " + std::strerror(errno));
  }
  std::ofstream& stream() { return out_; }
  void close()
  {
    out_.close();
    if (!out_)
      throw std::runtime_error("cannot write " + path_ + ": write failed (disk full?)");
  }

private:
  std::string path_;
  std::ofstream out_;
};
}  // namespace

void writeText(const std::string& path, const std::string& text)
{
  OutFile f(path);
  f.stream() << text;
  f.close();
}

void writeNpy(const std::string& path, const Grid& grid)
{
  if (grid.values.size() != grid.width * grid.height)
    throw std::invalid_argument("writeNpy " + path + ": the grid has " + std::to_string(grid.values.size()) +
                                " values for " + std::to_string(grid.width) + " x " + std::to_string(grid.height));
  std::string header = "{'descr': '<f4', 'fortran_order': False, 'shape': (" + std::to_string(grid.height) + ", " +
                       std::to_string(grid.width) + "), }";
  // Magic (6) + version (2) + header length (2) + header, padded with spaces to a multiple of
  // 64 bytes and ended by a newline (NumPy's format, version 1.0).
  const std::size_t unpadded = 10 + header.size() + 1;
  header.append((64 - unpadded % 64) % 64, ' ');
  header += '\n';
  OutFile f(path);
  std::ofstream& out = f.stream();
  out.write("\x93NUMPY\x01\x00", 8);
  const auto n = static_cast<std::uint16_t>(header.size());
  const char len[2] = { static_cast<char>(n & 0xff), static_cast<char>(n >> 8) };
  out.write(len, 2);
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  static_assert(sizeof(float) == 4, "float32");
  // x86-64 and ARM are little-endian, as '<f4' says.
  out.write(reinterpret_cast<const char*>(grid.values.data()),
            static_cast<std::streamsize>(grid.values.size() * sizeof(float)));
  f.close();
}

Json gridJson(const std::string& file, const Grid& grid)
{
  Json j = Json::object();
  j.set("file", file);
  j.set("origin_x", grid.origin_x);
  j.set("origin_y", grid.origin_y);
  j.set("resolution", grid.resolution);
  j.set("width", grid.width);
  j.set("height", grid.height);
  return j;
}

struct SpooledTable::Group
{
  std::string path;
  std::ofstream out;
  std::size_t rows = 0;
};

SpooledTable::SpooledTable(const std::string& spool_dir, const std::string& stem, const std::string& header,
                           std::size_t groups)
  : header_(header)
{
  for (std::size_t k = 0; k < groups; ++k)
  {
    auto g = std::make_unique<Group>();
    g->path = spool_dir + "/." + stem + "." + std::to_string(k) + ".part";
    g->out.open(g->path, std::ios::binary | std::ios::trunc);
    if (!g->out)
      throw std::runtime_error("cannot write " + g->path + ": " + std::strerror(errno));
    groups_.push_back(std::move(g));
  }
}

SpooledTable::~SpooledTable()
{
  for (const auto& g : groups_)
  {
    g->out.close();
    std::remove(g->path.c_str());
  }
}

void SpooledTable::add(std::size_t k, const std::string& row)
{
  Group& g = *groups_.at(k);
  g.out << row;
  if (!g.out)
    throw std::runtime_error("cannot write " + g.path + ": write failed (disk full?)");
  ++g.rows;
}

std::size_t SpooledTable::rows(std::size_t k) const
{
  return groups_.at(k)->rows;
}

void SpooledTable::write(const std::string& path, const std::vector<std::string>& extra)
{
  OutFile f(path);
  std::ofstream& out = f.stream();
  out << header_ << '\n';
  for (std::size_t k = 0; k < groups_.size(); ++k)
  {
    Group& g = *groups_[k];
    g.out.flush();
    if (!g.out)
      throw std::runtime_error("cannot write " + g.path + ": write failed (disk full?)");
    std::ifstream in(g.path, std::ios::binary);
    if (!in)
      throw std::runtime_error("cannot read " + g.path + ": " + std::strerror(errno));
    if (g.rows > 0)
      out << in.rdbuf();
    if (in.bad())
      throw std::runtime_error("cannot read " + g.path);
    if (k < extra.size())
      out << extra[k];
  }
  f.close();
}

TrajectoryTable::TrajectoryTable(const std::string& spool_dir, const std::vector<std::string>& names, double period)
  : names_(names), table_(spool_dir, "trajectories", "vehicle,t,x,y,z,speed,distance", names.size())
{
  if (!(period > 0.0) || !std::isfinite(period))
    throw std::invalid_argument("TrajectoryTable: period must be > 0 s");
  last_.assign(names.size(), Last(period));
}

std::string TrajectoryTable::row(std::size_t k, const OdometrySample& s) const
{
  char line[256];
  std::snprintf(line, sizeof line, ",%.3f,%.3f,%.3f,%.3f,%.3f,%.3f\n", s.t, s.x, s.y, s.z, s.speed, s.distance);
  return names_[k] + line;
}

void TrajectoryTable::add(std::size_t k, const OdometrySample& s)
{
  Last& l = last_.at(k);
  l.sample = s;
  l.any = true;
  l.written = l.pick.take(s.t);
  if (l.written)
    table_.add(k, row(k, s));
}

void TrajectoryTable::write(const std::string& path)
{
  std::vector<std::string> extra;
  for (std::size_t k = 0; k < last_.size(); ++k)
    extra.push_back(last_[k].any && !last_[k].written ? row(k, last_[k].sample) : "");
  table_.write(path, extra);
}

std::string gapRow(const std::string& follower, const std::string& leader, const GapSample& g)
{
  char line[128];
  std::snprintf(line, sizeof line, ",%.3f,%.3f,%.3f\n", g.t, g.gap, g.lateral);
  return follower + "," + leader + line;
}

}  // namespace results
}  // namespace avsp
