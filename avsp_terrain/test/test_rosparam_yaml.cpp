// YAML typed as rosparam types it (PyYAML's safe_load): checked against PyYAML itself, and the
// flow text the launch generator writes read back by PyYAML with the same types and values.
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "avsp_terrain/rosparam_yaml.hpp"

using avsp::terrain::rosparamDouble;
using avsp::terrain::rosparamFlow;
using avsp::terrain::RosparamScalar;
using avsp::terrain::rosparamScalar;
using avsp::terrain::rosparamTyped;

namespace
{
/// What Debian's python3-yaml (the PyYAML roslaunch and rosparam use) prints for a script.
std::string python(const std::string& script, const std::string& input)
{
  const std::string dir = testing::TempDir();
  const std::string script_file = dir + "/rosparam_yaml_check.py", input_file = dir + "/rosparam_yaml_input.txt";
  std::ofstream(script_file) << script;
  std::ofstream(input_file) << input;
  const std::string command = "/usr/bin/python3 " + script_file + " < " + input_file + " 2>&1";
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(command.c_str(), "r"), pclose);
  if (!pipe)
    return "popen failed";
  std::string out;
  std::array<char, 4096> buf{};
  while (std::fgets(buf.data(), buf.size(), pipe.get()))
    out += buf.data();
  return out;
}

/// Kind and value as the Python script below prints them: "bool 1", "int 8", "float 0.5", "str x".
std::string described(const RosparamScalar& s, const std::string& text)
{
  char buf[64];
  switch (s.kind)
  {
    case RosparamScalar::Kind::kNull:
      return "null";
    case RosparamScalar::Kind::kBool:
      return std::string("bool ") + (s.boolean ? "1" : "0");
    case RosparamScalar::Kind::kInt:
      return "int " + std::to_string(s.integer);
    case RosparamScalar::Kind::kDouble:
      if (std::isnan(s.real))
        return "float nan";
      if (std::isinf(s.real))
        return s.real > 0 ? "float inf" : "float -inf";
      std::snprintf(buf, sizeof buf, "float %.17g", s.real);
      return buf;
    case RosparamScalar::Kind::kString:
      return "str " + text;
  }
  return "?";
}

const char* const kDescribe = R"(import sys, yaml
for line in sys.stdin.read().split('\n')[:-1]:
    v = yaml.safe_load(line) if line else None
    if v is None: print('null')
    elif isinstance(v, bool): print('bool', int(v))
    elif isinstance(v, int): print('int', v)
    elif isinstance(v, float):
        print('float', 'nan' if v != v else ('inf' if v == float('inf') else ('-inf' if v == -float('inf') else '%.17g' % v)))
    else: print('str', line)
)";
}  // namespace

TEST(RosparamYaml, PlainScalarsAreTypedAsPyYamlTypesThem)
{
  // Every resolver of PyYAML 6 and the places where YAML 1.1 and 1.2 (yaml-cpp) differ.
  const std::vector<std::string> scalars = {
    "true",       "True",     "TRUE",
    "false",      "yes",      "Yes",
    "NO",         "on",       "Off",
    "y",          "n",        "Y",
    "tRue",       "0",        "42",
    "-7",         "+3",       "1_000",
    "010",        "-017",     "0x1f",
    "0X1F",       "0b101",    "-0b11",
    "1:30",       "-1:02:03", "08",
    "0.5",        "-0.5",     ".5",
    "-.5",        "+.5",      "1.",
    "1.0e+3",     "1.0e3",    "1e3",
    "5e-3",       "1.5e3",    "1.e3",
    "2E-2",       "2.0E-2",   "3.25E+2",
    "1_000.5",    "1:30.5",   ".inf",
    "-.inf",      "+.Inf",    ".INF",
    ".nan",       ".NaN",     "inf",
    "nan",        "NaN",      "~",
    "null",       "Null",     "NULL",
    "none",       "VLP-16",   "2026-06-01",
    "12:00:00",   "0o17",     "1,000",
    "--1",        "1e",       "0.1.2",
    "_1",         "1__2",     "9223372036854775807",
    "2147483648",
  };
  std::string input, expected;
  for (const std::string& s : scalars)
  {
    input += s + "\n";
    expected += described(rosparamScalar(s), s) + "\n";
  }
  const std::string pyyaml = python(kDescribe, input);
  // Line by line, so that a failure names the scalar.
  std::istringstream want(pyyaml), got(expected);
  std::string w, g;
  for (const std::string& s : scalars)
  {
    ASSERT_TRUE(std::getline(want, w)) << "PyYAML printed less than expected:\n" << pyyaml;
    std::getline(got, g);
    EXPECT_EQ(g, w) << "scalar '" << s << "'";
  }
}

TEST(RosparamYaml, DoublesReadBackExactly)
{
  for (const double v : { 0.0, -0.0, 1.0, -3.0, 0.1, 1.0 / 3.0, 600.0, 1e-7, 1e20, -2.5e300, 5e-324, 123456789.125 })
  {
    const std::string s = rosparamDouble(v);
    const RosparamScalar r = rosparamScalar(s);
    EXPECT_EQ(r.kind, RosparamScalar::Kind::kDouble) << s;
    EXPECT_EQ(r.real, v) << s;
    EXPECT_EQ(std::signbit(r.real), std::signbit(v)) << s;
  }
  EXPECT_EQ(rosparamDouble(600.0), "600.0");
  EXPECT_EQ(rosparamDouble(1e20), "1.0e+20");  // %g's 1e+20 is a string to PyYAML
  EXPECT_EQ(rosparamDouble(0.1), "0.1");
  EXPECT_EQ(rosparamDouble(-std::numeric_limits<double>::infinity()), "-.inf");
  EXPECT_EQ(rosparamDouble(std::nan("")), ".nan");
}

// What the launch generator writes into <rosparam> bodies: PyYAML reads it back with the types
// rosparamTyped gives, whatever the scenario's own spelling (yaml-cpp reads 1e3 as a number,
// PyYAML as text; yes is a boolean to PyYAML).
TEST(RosparamYaml, FlowTextReadsBackInPyYamlWithTheTypedValues)
{
  const YAML::Node source = YAML::Load(
      "{lidar: {preset: VLP-16, max_range: 1e3, columns: 0x10, rate: 1.0e+1, on: yes, off: 'yes', name: \"a\\\"b\"},"
      " list: [1, 2.5, y, .inf, -.5, 1:30, 'quoted', \"two\\nlines\"], nested: [{k: 5}], empty: {}}");
  const std::string flow = rosparamFlow(source);
  const char* const kJson = R"(import sys, yaml, json, math
def clean(v):
    if isinstance(v, float) and (math.isinf(v) or math.isnan(v)): return repr(v)
    if isinstance(v, dict): return {k: clean(x) for k, x in v.items()}
    if isinstance(v, list): return [clean(x) for x in v]
    return v
print(json.dumps(clean(yaml.safe_load(sys.stdin.read())), sort_keys=True))
)";
  EXPECT_EQ(
      python(kJson, flow),
      "{\"empty\": {}, \"lidar\": {\"columns\": 16, \"max_range\": \"1e3\", \"name\": \"a\\\"b\", \"off\": "
      "\"yes\", \"on\": true, \"preset\": \"VLP-16\", \"rate\": 10.0}, \"list\": [1, 2.5, \"y\", \"inf\", \"-.5\", "
      "90, \"quoted\", \"two\\nlines\"], \"nested\": [{\"k\": 5}]}\n")
      << flow;
  // Typed once or twice, the same text (the scenario stores typed sections, the generator types
  // them again).
  EXPECT_EQ(rosparamFlow(rosparamTyped(source)), flow);
  EXPECT_EQ(rosparamFlow(rosparamTyped(source, true), true), rosparamFlow(source, true));
  EXPECT_EQ(rosparamFlow(YAML::Load("{a: 50, b: true, c: \"50\", d: [1, x]}"), true),
            "{\"a\": 50.0, \"b\": true, \"c\": \"50\", \"d\": [1.0, \"x\"]}");
}

TEST(RosparamYaml, NullsAreRefusedNamingThePath)
{
  try
  {
    rosparamTyped(YAML::Load("{lidar: {rate: ~}}"), false, "sensors");
    FAIL() << "a null passed";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_STREQ(e.what(), "sensors.lidar.rate: a null value (rosparam cannot set it)");
  }
  EXPECT_THROW(rosparamTyped(YAML::Load("[1, null]"), false, "agents"), std::invalid_argument);
}
