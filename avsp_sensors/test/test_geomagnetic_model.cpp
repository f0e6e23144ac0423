// The World Magnetic Model 2025 as shipped (data/magnetic/wmm2025.wmm, .wmm.cof) through
// GeographicLib: NOAA's published test values, the model's validity in time and height, bad and
// corrupt model files, dates, and the field over the map (MapMagneticField).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

#include "avsp_sensors/geomagnetic_model.hpp"
#include "avsp_sensors/magnetometer.hpp"

using namespace avsp::sensors;

namespace
{
const std::string kWmm2025 = std::string(AVSP_SENSORS_DATA_DIR) + "/magnetic/wmm2025.wmm";

// NOAA NCEI, "WMM2025 test values": WMM2025_TestValues.txt, distributed with the coefficients in
// WMM2025COF.zip (World Magnetic Model 2025 release, 2024-12-17), its first 10 rows of 100.
// Columns: decimal year, height above the WGS-84 ellipsoid (km), geodetic latitude and
// longitude (deg), D and I (deg, printed to 0.01), H, X (north), Y (east), Z (down), F (nT).
struct NoaaTestValue
{
  double year, height_km, lat, lon, d, i, h, x, y, z, f;
};
const NoaaTestValue kNoaa[] = {
  { 2025.0, 28, 89, -121, -99.77, 88.47, 1504.298146, -255.388723, -1482.460628, 56194.288771, 56214.419888 },
  { 2025.0, 65, 43, 93, 0.50, 64.10, 24300.764692, 24299.852822, 210.517066, 50037.923998, 55626.621348 },
  { 2025.0, 51, -33, 109, -5.49, -67.50, 21838.046477, 21737.778822, -2090.274098, -52710.00392, 57054.752538 },
  { 2025.5, 6, -36, -137, 20.28, -52.11, 25353.230658, 23781.930678, 8786.698927, -32577.518648, 41280.516301 },
  { 2025.5, 8, -66, 17, -33.14, -59.55, 18154.870136, 15201.438652, -9925.501123, -30881.123197, 35822.382382 },
  { 2026.0, 74, -57, 3, -22.51, -58.65, 14362.206593, 13268.119649, -5498.179626, -23576.062921, 27606.226129 },
  { 2026.0, 62, -14, 99, -1.43, -44.70, 33448.275663, 33437.82863, -835.919473, -33100.922253, 47058.03012 },
  { 2026.5, 14, 0, 80, -3.10, -17.15, 39489.089663, 39431.415992, -2133.456168, -12188.838466, 41327.424134 },
  { 2027.0, 37, -66, -5, -17.22, -59.04, 17159.8365, 16390.771268, -5079.626554, -28608.243575, 33360.029814 },
  { 2027.5, 73, -72, 95, -102.64, -76.49, 13306.747292, -2912.418045, -12984.118939, -55399.217725, 56974.931751 },
};
constexpr double kNanoTesla = 1e-9;

std::string thrown(const std::function<void()>& f)
{
  try
  {
    f();
  }
  catch (const GeomagneticModelError& e)
  {
    return e.what();
  }
  return "";
}

#define EXPECT_MENTIONS(text, part) EXPECT_NE((text).find(part), std::string::npos) << (text)

/// A copy of the shipped model in a fresh folder, to be broken by the test.
struct ModelCopy
{
  std::string dir, wmm;
  explicit ModelCopy(const std::string& name)
  {
    char tmpl[] = "/tmp/avsp_test_wmm_XXXXXX";
    dir = mkdtemp(tmpl);
    wmm = dir + "/" + name + ".wmm";
    write(wmm, read(kWmm2025));
    write(wmm + ".cof", read(kWmm2025 + ".cof"));
  }
  ~ModelCopy()
  {
    std::remove(wmm.c_str());
    std::remove((wmm + ".cof").c_str());
    std::remove(dir.c_str());
  }
  static std::string read(const std::string& path)
  {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  static void write(const std::string& path, const std::string& bytes)
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << bytes;
  }
};
}  // namespace

TEST(GeomagneticModel, ShippedFileIsTheWmm2025)
{
  const GeomagneticModel m(kWmm2025);
  EXPECT_EQ(m.name(), "wmm2025");
  EXPECT_EQ(m.description(), "World Magnetic Model 2025");
  EXPECT_EQ(m.minYear(), 2025.0);
  EXPECT_EQ(m.maxYear(), 2030.0);
  EXPECT_EQ(m.minHeight(), -1000.0);
  EXPECT_EQ(m.maxHeight(), 850000.0);
}

TEST(GeomagneticModel, MatchesNoaaTestValues)
{
  // NOAA prints the components to 1e-6 nT and D, I to 0.01 deg: within 0.01 nT and 0.005 deg
  // (half the last printed digit) is as tight as the table allows.
  const GeomagneticModel m(kWmm2025);
  for (const NoaaTestValue& v : kNoaa)
  {
    const Eigen::Vector3d b = m.fieldEnu({ v.lat, v.lon, v.height_km * 1000.0 }, v.year);  // east, north, up
    const std::string row = std::to_string(v.year) + " " + std::to_string(v.lat) + " " + std::to_string(v.lon);
    EXPECT_NEAR(b.y() / kNanoTesla, v.x, 0.01) << row;   // X, north
    EXPECT_NEAR(b.x() / kNanoTesla, v.y, 0.01) << row;   // Y, east
    EXPECT_NEAR(-b.z() / kNanoTesla, v.z, 0.01) << row;  // Z, down
    EXPECT_NEAR(b.head<2>().norm() / kNanoTesla, v.h, 0.01) << row;
    const EarthField f = earthFieldFromEnu(b);
    EXPECT_NEAR(f.intensity / kNanoTesla, v.f, 0.01) << row;
    EXPECT_NEAR(f.declination_deg, v.d, 0.005) << row;
    EXPECT_NEAR(f.inclination_deg, v.i, 0.005) << row;
  }
}

TEST(GeomagneticModel, DatesOutsideTheValidityAreRefusedNamingTheRange)
{
  const GeomagneticModel m(kWmm2025);
  const Geodetic p{ 39.7425, -105.1786, 1829.0 };
  EXPECT_NO_THROW(m.fieldEnu(p, 2025.0));
  EXPECT_NO_THROW(m.fieldEnu(p, 2030.0));
  for (double year : { 2024.999, 2030.001, 2031.0, std::nan("") })
  {
    const std::string why = thrown([&] { m.fieldEnu(p, year); });
    EXPECT_MENTIONS(why, "valid for decimal years 2025.0 to 2030.0");
    EXPECT_MENTIONS(why, kWmm2025);
  }
}

TEST(GeomagneticModel, HeightsOutsideTheValidityAreRefused)
{
  const GeomagneticModel m(kWmm2025);
  EXPECT_NO_THROW(m.fieldEnu({ 0.0, 0.0, -1000.0 }, 2026.0));
  EXPECT_MENTIONS(thrown([&] { m.fieldEnu({ 0.0, 0.0, -1500.0 }, 2026.0); }), "valid from -1000 to 850000 m");
  EXPECT_MENTIONS(thrown([&] { m.fieldEnu({ 0.0, 0.0, 900e3 }, 2026.0); }), "the point is at 900000.0 m");
  EXPECT_MENTIONS(thrown([&] { m.fieldEnu({ 91.0, 0.0, 0.0 }, 2026.0); }), "not a valid position");
}

TEST(GeomagneticModel, DecimalYearIsTheWmmTimeScale)
{
  // year + (day of the year - 1) / (days in the year)
  EXPECT_DOUBLE_EQ(decimalYear("2025-01-01"), 2025.0);
  EXPECT_DOUBLE_EQ(decimalYear("2025-10-15"), 2025.0 + 287.0 / 365.0);
  EXPECT_DOUBLE_EQ(decimalYear("2028-12-31"), 2028.0 + 365.0 / 366.0);  // a leap year
  EXPECT_DOUBLE_EQ(decimalYear("2027.5"), 2027.5);
  for (const char* bad : { "", "now", "yesterday", "2025-13-01", "2025-02-30", "2025-10-15T15:00:00Z" })
    EXPECT_MENTIONS(thrown([&] { decimalYear(bad); }), "date '" + std::string(bad) + "'");
}

TEST(GeomagneticModel, MissingFileIsNamed)
{
  const std::string why = thrown([] { GeomagneticModel("/nonexistent/wmm2025.wmm"); });
  EXPECT_MENTIONS(why, "magnetic model file /nonexistent/wmm2025.wmm");
  EXPECT_MENTIONS(thrown([] { GeomagneticModel(std::string(AVSP_SENSORS_DATA_DIR) + "/magnetic/wmm2025.cof"); }),
                  "must end in .wmm");
}

TEST(GeomagneticModel, CorruptFilesAreRefusedWithTheReason)
{
  {  // coefficients cut short
    ModelCopy copy("short");
    const std::string cof = ModelCopy::read(copy.wmm + ".cof");
    ModelCopy::write(copy.wmm + ".cof", cof.substr(0, cof.size() - 100));
    EXPECT_MENTIONS(thrown([&] { GeomagneticModel m(copy.wmm); }), "magnetic model file " + copy.wmm);
  }
  {  // coefficients with bytes left over
    ModelCopy copy("long");
    ModelCopy::write(copy.wmm + ".cof", ModelCopy::read(copy.wmm + ".cof") + "extra");
    EXPECT_MENTIONS(thrown([&] { GeomagneticModel m(copy.wmm); }), "magnetic model file " + copy.wmm);
  }
  {  // coefficients of another model (the ID at the start differs from the metadata's)
    ModelCopy copy("other_id");
    std::string cof = ModelCopy::read(copy.wmm + ".cof");
    cof[7] = 'B';
    ModelCopy::write(copy.wmm + ".cof", cof);
    EXPECT_MENTIONS(thrown([&] { GeomagneticModel m(copy.wmm); }), "ID");
  }
  {  // metadata that is not a GeographicLib magnetic model
    ModelCopy copy("not_wmm");
    ModelCopy::write(copy.wmm, "just some text\n");
    EXPECT_MENTIONS(thrown([&] { GeomagneticModel m(copy.wmm); }), "WMMF");
  }
  {  // metadata without its validity in time
    ModelCopy copy("no_max_time");
    std::string meta = ModelCopy::read(copy.wmm);
    meta.replace(meta.find("\nMaxTime"), 8, "\n#axTime");  // the key line, not the comments' mention
    ModelCopy::write(copy.wmm, meta);
    EXPECT_MENTIONS(thrown([&] { GeomagneticModel m(copy.wmm); }), "magnetic model file " + copy.wmm);
  }
}

TEST(MapMagneticField, IsTheModelAtTheOriginAndTurnsIntoTheMapAxesAway)
{
  const GeomagneticModel m(kWmm2025);
  const double year = 2026.25;
  // At the equator the local axes 100 km east are the map's turned by t = atan(100 km / a)
  // about north (test_geodetic: LocalAxesAtAnEastOffset...).
  const EnuFrame map({ 0.0, 80.0, 0.0 });
  const MapMagneticField field(m, map, year);
  EXPECT_LT((field.at(Eigen::Vector3d::Zero()) - m.fieldEnu({ 0.0, 80.0, 0.0 }, year)).norm(), 1e-15);
  const Eigen::Vector3d p(100e3, 0.0, 0.0);
  const Geodetic g = map.toGeodetic(p);
  const Eigen::Vector3d local = m.fieldEnu(g, year);
  const double t = std::atan(100e3 / 6378137.0);
  const Eigen::Vector3d expected(std::cos(t) * local.x() + std::sin(t) * local.z(), local.y(),
                                 -std::sin(t) * local.x() + std::cos(t) * local.z());
  EXPECT_LT((field.at(p) - expected).norm(), 1e-15);
  // The field itself changes over 100 km (the model is not a constant): by more than 100 nT here.
  EXPECT_GT((field.at(p) - field.at(Eigen::Vector3d::Zero())).norm(), 100e-9);
}

TEST(MapMagneticField, RefusesADateOrAnOriginOutsideTheModel)
{
  const GeomagneticModel m(kWmm2025);
  EXPECT_MENTIONS(thrown([&] {
                    MapMagneticField(m, EnuFrame({ 39.7, -105.2, 1829.0 }), 2031.0);
                  }),
                  "the date is 2031.000");
  EXPECT_MENTIONS(thrown([&] {
                    MapMagneticField(m, EnuFrame({ 39.7, -105.2, -5000.0 }), 2026.0);
                  }),
                  "the point is at -5000.0 m");
}
