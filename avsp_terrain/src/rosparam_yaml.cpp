#include "avsp_terrain/rosparam_yaml.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <regex>
#include <sstream>
#include <stdexcept>

namespace avsp
{
namespace terrain
{
namespace
{
// PyYAML 6's implicit resolvers (resolver.py), in the order it tries them for a scalar's first
// character: bool, float, int, null. (Timestamps and '<<' are left as text: rosparam cannot set
// a date, and a scenario has no merge keys.)
const std::regex kBool("yes|Yes|YES|no|No|NO|true|True|TRUE|false|False|FALSE|on|On|ON|off|Off|OFF");
const std::regex kFloat(
    "[-+]?([0-9][0-9_]*)\\.[0-9_]*([eE][-+][0-9]+)?"
    "|\\.[0-9][0-9_]*([eE][-+][0-9]+)?"
    "|[-+]?[0-9][0-9_]*(:[0-5]?[0-9])+\\.[0-9_]*"
    "|[-+]?\\.(inf|Inf|INF)"
    "|\\.(nan|NaN|NAN)");
const std::regex kInt(
    "[-+]?0b[0-1_]+"
    "|[-+]?0[0-7_]+"
    "|[-+]?(0|[1-9][0-9_]*)"
    "|[-+]?0x[0-9a-fA-F_]+"
    "|[-+]?[1-9][0-9_]*(:[0-5]?[0-9])+");
const std::regex kNull("~|null|Null|NULL|");

std::string withoutUnderscores(const std::string& s)
{
  std::string out;
  for (const char c : s)
    if (c != '_')
      out += c;
  return out;
}

/// Sexagesimal "a:b:c" (digits only after the sign) as PyYAML sums it: ((a * 60) + b) * 60 + c.
double sexagesimal(const std::string& digits)
{
  double value = 0.0;
  std::size_t start = 0;
  while (true)
  {
    const std::size_t colon = digits.find(':', start);
    const std::string part = digits.substr(start, colon == std::string::npos ? std::string::npos : colon - start);
    value = value * 60.0 + std::strtod(part.c_str(), nullptr);
    if (colon == std::string::npos)
      return value;
    start = colon + 1;
  }
}

RosparamScalar integer(const std::string& text)
{
  std::string v = withoutUnderscores(text);
  int sign = 1;
  if (!v.empty() && (v[0] == '-' || v[0] == '+'))
  {
    sign = v[0] == '-' ? -1 : 1;
    v = v.substr(1);
  }
  RosparamScalar s;
  s.kind = RosparamScalar::Kind::kInt;
  double magnitude = 0.0;
  errno = 0;
  unsigned long long u = 0;
  if (v == "0")
    u = 0;
  else if (v.rfind("0b", 0) == 0)
    u = std::strtoull(v.c_str() + 2, nullptr, 2);
  else if (v.rfind("0x", 0) == 0)
    u = std::strtoull(v.c_str() + 2, nullptr, 16);
  else if (v.find(':') != std::string::npos)
    magnitude = sexagesimal(v);
  else if (v[0] == '0')
    u = std::strtoull(v.c_str() + 1, nullptr, 8);
  else
    u = std::strtoull(v.c_str(), nullptr, 10);
  if (v.find(':') == std::string::npos)
    magnitude = errno == ERANGE ? std::numeric_limits<double>::infinity() : static_cast<double>(u);
  s.real = sign * magnitude;
  const double limit = static_cast<double>(std::numeric_limits<long long>::max());
  if (v.find(':') == std::string::npos && errno != ERANGE &&
      u <= static_cast<unsigned long long>(std::numeric_limits<long long>::max()))
    s.integer = sign * static_cast<long long>(u);
  else
    s.integer = magnitude >= limit
                    ? (sign > 0 ? std::numeric_limits<long long>::max() : std::numeric_limits<long long>::min())
                    : sign * static_cast<long long>(magnitude);
  return s;
}

RosparamScalar real(const std::string& text)
{
  std::string v = withoutUnderscores(text);
  for (char& c : v)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  double sign = 1.0;
  if (!v.empty() && (v[0] == '-' || v[0] == '+'))
  {
    sign = v[0] == '-' ? -1.0 : 1.0;
    v = v.substr(1);
  }
  RosparamScalar s;
  s.kind = RosparamScalar::Kind::kDouble;
  if (v == ".inf")
    s.real = sign * std::numeric_limits<double>::infinity();
  else if (v == ".nan")
    s.real = std::numeric_limits<double>::quiet_NaN();
  else if (v.find(':') != std::string::npos)
    s.real = sign * sexagesimal(v);
  else
    s.real = sign * std::strtod(v.c_str(), nullptr);
  return s;
}

/// Double-quoted with YAML's escapes, so that any text (a quote, a backslash, a line break)
/// reads back as itself.
void emitQuoted(std::ostream& out, const std::string& text)
{
  out << '"';
  for (const char c : text)
  {
    switch (c)
    {
      case '"':
        out << "\\\"";
        break;
      case '\\':
        out << "\\\\";
        break;
      case '\n':
        out << "\\n";
        break;
      case '\t':
        out << "\\t";
        break;
      case '\r':
        out << "\\r";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20)
        {
          char hex[8];
          std::snprintf(hex, sizeof hex, "\\x%02x", static_cast<unsigned char>(c));
          out << hex;
        }
        else
          out << c;
    }
  }
  out << '"';
}

void emit(std::ostream& out, const YAML::Node& typed)
{
  switch (typed.Type())
  {
    case YAML::NodeType::Map:
    {
      out << "{";
      bool first = true;
      for (const auto& kv : typed)
      {
        out << (first ? "" : ", ");
        emitQuoted(out, kv.first.Scalar());
        out << ": ";
        emit(out, kv.second);
        first = false;
      }
      out << "}";
      break;
    }
    case YAML::NodeType::Sequence:
    {
      out << "[";
      for (std::size_t i = 0; i < typed.size(); ++i)
      {
        out << (i ? ", " : "");
        emit(out, typed[i]);
      }
      out << "]";
      break;
    }
    default:
      if (typed.Tag() == "!")
        emitQuoted(out, typed.Scalar());
      else
        out << typed.Scalar();  // canonical bool, integer or double (rosparamTyped)
  }
}
}  // namespace

RosparamScalar rosparamScalar(const std::string& text)
{
  RosparamScalar s;
  if (std::regex_match(text, kBool))
  {
    s.kind = RosparamScalar::Kind::kBool;
    s.boolean = text[0] == 'y' || text[0] == 'Y' || text[0] == 't' || text[0] == 'T' || text == "on" || text == "On" ||
                text == "ON";
    return s;
  }
  if (std::regex_match(text, kFloat))
    return real(text);
  if (std::regex_match(text, kInt))
    return integer(text);
  if (std::regex_match(text, kNull))
  {
    s.kind = RosparamScalar::Kind::kNull;
    return s;
  }
  return s;  // a string
}

std::string rosparamDouble(double v)
{
  if (std::isnan(v))
    return ".nan";
  if (std::isinf(v))
    return v > 0 ? ".inf" : "-.inf";
  char buf[64];
  for (int precision = 15; precision <= 17; ++precision)
  {
    std::snprintf(buf, sizeof buf, "%.*g", precision, v);
    if (std::strtod(buf, nullptr) == v)
      break;
  }
  std::string s = buf;
  // PyYAML's floats need a '.' (and %g always signs its exponent): 1e+20 -> 1.0e+20, 5 -> 5.0.
  if (s.find('.') == std::string::npos)
  {
    const std::size_t e = s.find_first_of("eE");
    s.insert(e == std::string::npos ? s.size() : e, ".0");
  }
  return s;
}

YAML::Node rosparamTyped(const YAML::Node& node, bool force_double, const std::string& path)
{
  const std::string where = path.empty() ? "the value" : path;
  switch (node.Type())
  {
    case YAML::NodeType::Map:
    {
      YAML::Node out(YAML::NodeType::Map);
      for (const auto& kv : node)
      {
        if (!kv.first.IsScalar())
          throw std::invalid_argument(where + ": a map key that is not a string");
        const std::string key = kv.first.Scalar();
        out[key] = rosparamTyped(kv.second, force_double, path.empty() ? key : path + "." + key);
      }
      return out;
    }
    case YAML::NodeType::Sequence:
    {
      YAML::Node out(YAML::NodeType::Sequence);
      for (std::size_t k = 0; k < node.size(); ++k)
        out.push_back(rosparamTyped(node[k], force_double, where + "[" + std::to_string(k) + "]"));
      return out;
    }
    case YAML::NodeType::Scalar:
    {
      YAML::Node out;
      if (node.Tag() == "!")  // quoted in the source: a string whatever it spells
      {
        out = YAML::Node(node.Scalar());
        out.SetTag("!");
        return out;
      }
      const RosparamScalar s = rosparamScalar(node.Scalar());
      switch (s.kind)
      {
        case RosparamScalar::Kind::kBool:
          return YAML::Node(s.boolean ? "true" : "false");
        case RosparamScalar::Kind::kInt:
          return YAML::Node(force_double ? rosparamDouble(s.real) : std::to_string(s.integer));
        case RosparamScalar::Kind::kDouble:
          return YAML::Node(rosparamDouble(s.real));
        case RosparamScalar::Kind::kNull:
          throw std::invalid_argument(where + ": a null value (rosparam cannot set it)");
        case RosparamScalar::Kind::kString:
          out = YAML::Node(node.Scalar());
          out.SetTag("!");
          return out;
      }
      return out;
    }
    default:
      throw std::invalid_argument(where + ": a null value (rosparam cannot set it)");
  }
}

std::string rosparamFlow(const YAML::Node& node, bool force_double)
{
  std::ostringstream out;
  emit(out, rosparamTyped(node, force_double));
  return out.str();
}

}  // namespace terrain
}  // namespace avsp
