// Sun and Moon positions (see astronomy.hpp for the sources and their accuracy). Angles in
// the series are in degrees, as in Meeus' tables; everything public is in radians.
#include "avsp/environment/astronomy.hpp"

#include <cmath>
#include <cstdio>
#include <iomanip>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <GeographicLib/Geocentric.hpp>

namespace avsp
{
namespace environment
{
namespace
{
constexpr double kJ2000 = 2451545.0;
constexpr double kDaysPerCentury = 36525.0;
constexpr double kArcsecToDeg = 1.0 / 3600.0;

/// Angle in degrees reduced to [0, 360).
double wrapDeg(double a)
{
  a = std::fmod(a, 360.0);
  return a < 0.0 ? a + 360.0 : a;
}

double wrapRad(double a)
{
  a = std::fmod(a, 2.0 * kPi);
  return a < 0.0 ? a + 2.0 * kPi : a;
}

double sinD(double deg)
{
  return std::sin(deg * kDegToRad);
}
double cosD(double deg)
{
  return std::cos(deg * kDegToRad);
}

/// Right ascension and declination (rad) from ecliptic longitude/latitude (rad) and obliquity (rad).
void eclipticToEquatorial(double lambda, double beta, double eps, double& ra, double& dec)
{
  ra = wrapRad(std::atan2(std::sin(lambda) * std::cos(eps) - std::tan(beta) * std::sin(eps), std::cos(lambda)));
  dec = std::asin(std::sin(beta) * std::cos(eps) + std::cos(beta) * std::sin(eps) * std::sin(lambda));
}

/// One periodic term of Meeus tables 47.A / 47.B: multiples of D, M, M', F and the
/// coefficients (1e-6 deg for longitude and latitude, 1e-3 km for distance).
struct LunarTerm
{
  int d, m, mp, f;
  double sine, cosine;
};

// Table 47.A: longitude (sine terms) and distance (cosine terms).
constexpr LunarTerm kLongitudeDistance[] = {
  { 0, 0, 1, 0, 6288774, -20905355 },
  { 2, 0, -1, 0, 1274027, -3699111 },
  { 2, 0, 0, 0, 658314, -2955968 },
  { 0, 0, 2, 0, 213618, -569925 },
  { 0, 1, 0, 0, -185116, 48888 },
  { 0, 0, 0, 2, -114332, -3149 },
  { 2, 0, -2, 0, 58793, 246158 },
  { 2, -1, -1, 0, 57066, -152138 },
  { 2, 0, 1, 0, 53322, -170733 },
  { 2, -1, 0, 0, 45758, -204586 },
  { 0, 1, -1, 0, -40923, -129620 },
  { 1, 0, 0, 0, -34720, 108743 },
  { 0, 1, 1, 0, -30383, 104755 },
  { 2, 0, 0, -2, 15327, 10321 },
  { 0, 0, 1, 2, -12528, 0 },
  { 0, 0, 1, -2, 10980, 79661 },
  { 4, 0, -1, 0, 10675, -34782 },
  { 0, 0, 3, 0, 10034, -23210 },
  { 4, 0, -2, 0, 8548, -21636 },
  { 2, 1, -1, 0, -7888, 24208 },
  { 2, 1, 0, 0, -6766, 30824 },
  { 1, 0, -1, 0, -5163, -8379 },
  { 1, 1, 0, 0, 4987, -16675 },
  { 2, -1, 1, 0, 4036, -12831 },
  { 2, 0, 2, 0, 3994, -10445 },
  { 4, 0, 0, 0, 3861, -11650 },
  { 2, 0, -3, 0, 3665, 14403 },
  { 0, 1, -2, 0, -2689, -7003 },
  { 2, 0, -1, 2, -2602, 0 },
  { 2, -1, -2, 0, 2390, 10056 },
  { 1, 0, 1, 0, -2348, 6322 },
  { 2, -2, 0, 0, 2236, -9884 },
  { 0, 1, 2, 0, -2120, 5751 },
  { 0, 2, 0, 0, -2069, 0 },
  { 2, -2, -1, 0, 2048, -4950 },
  { 2, 0, 1, -2, -1773, 4130 },
  { 2, 0, 0, 2, -1595, 0 },
  { 4, -1, -1, 0, 1215, -3958 },
  { 0, 0, 2, 2, -1110, 0 },
  { 3, 0, -1, 0, -892, 3258 },
  { 2, 1, 1, 0, -810, 2616 },
  { 4, -1, -2, 0, 759, -1897 },
  { 0, 2, -1, 0, -713, -2117 },
  { 2, 2, -1, 0, -700, 2354 },
  { 2, 1, -2, 0, 691, 0 },
  { 2, -1, 0, -2, 596, 0 },
  { 4, 0, 1, 0, 549, -1423 },
  { 0, 0, 4, 0, 537, -1117 },
  { 4, -1, 0, 0, 520, -1571 },
  { 1, 0, -2, 0, -487, -1739 },
  { 2, 1, 0, -2, -399, 0 },
  { 0, 0, 2, -2, -381, -4421 },
  { 1, 1, 1, 0, 351, 0 },
  { 3, 0, -2, 0, -340, 0 },
  { 4, 0, -3, 0, 330, 0 },
  { 2, -1, 2, 0, 327, 0 },
  { 0, 2, 1, 0, -323, 1165 },
  { 1, 1, -1, 0, 299, 0 },
  { 2, 0, 3, 0, 294, 0 },
  { 2, 0, -1, -2, 0, 8752 },
};

// Table 47.B: latitude (sine terms; `cosine` unused).
constexpr LunarTerm kLatitude[] = {
  { 0, 0, 0, 1, 5128122, 0 }, { 0, 0, 1, 1, 280602, 0 },  { 0, 0, 1, -1, 277693, 0 }, { 2, 0, 0, -1, 173237, 0 },
  { 2, 0, -1, 1, 55413, 0 },  { 2, 0, -1, -1, 46271, 0 }, { 2, 0, 0, 1, 32573, 0 },   { 0, 0, 2, 1, 17198, 0 },
  { 2, 0, 1, -1, 9266, 0 },   { 0, 0, 2, -1, 8822, 0 },   { 2, -1, 0, -1, 8216, 0 },  { 2, 0, -2, -1, 4324, 0 },
  { 2, 0, 1, 1, 4200, 0 },    { 2, 1, 0, -1, -3359, 0 },  { 2, -1, -1, 1, 2463, 0 },  { 2, -1, 0, 1, 2211, 0 },
  { 2, -1, -1, -1, 2065, 0 }, { 0, 1, -1, -1, -1870, 0 }, { 4, 0, -1, -1, 1828, 0 },  { 0, 1, 0, 1, -1794, 0 },
  { 0, 0, 0, 3, -1749, 0 },   { 0, 1, -1, 1, -1565, 0 },  { 1, 0, 0, 1, -1491, 0 },   { 0, 1, 1, 1, -1475, 0 },
  { 0, 1, 1, -1, -1410, 0 },  { 0, 1, 0, -1, -1344, 0 },  { 1, 0, 0, -1, -1335, 0 },  { 0, 0, 3, 1, 1107, 0 },
  { 4, 0, 0, -1, 1021, 0 },   { 4, 0, -1, 1, 833, 0 },    { 0, 0, 1, -3, 777, 0 },    { 4, 0, -2, 1, 671, 0 },
  { 2, 0, 0, -3, 607, 0 },    { 2, 0, 2, -1, 596, 0 },    { 2, -1, 1, -1, 491, 0 },   { 2, 0, -2, 1, -451, 0 },
  { 0, 0, 3, -1, 439, 0 },    { 2, 0, 2, 1, 422, 0 },     { 2, 0, -3, -1, 421, 0 },   { 2, 1, -1, 1, -366, 0 },
  { 2, 1, 0, 1, -351, 0 },    { 4, 0, 0, 1, 331, 0 },     { 2, -1, 1, 1, 315, 0 },    { 2, -2, 0, -1, 302, 0 },
  { 0, 0, 1, 3, -283, 0 },    { 2, 1, 1, -1, -229, 0 },   { 1, 1, 0, -1, 223, 0 },    { 1, 1, 0, 1, 223, 0 },
  { 0, 1, -2, -1, -220, 0 },  { 2, 1, -1, -1, -220, 0 },  { 1, 0, 1, 1, -185, 0 },    { 2, -1, -2, -1, 181, 0 },
  { 0, 1, 2, 1, -177, 0 },    { 4, 0, -2, -1, 176, 0 },   { 4, -1, -1, -1, 166, 0 },  { 1, 0, 1, -1, -164, 0 },
  { 4, 0, 1, -1, 132, 0 },    { 1, 0, -1, -1, -119, 0 },  { 4, -1, 0, -1, 115, 0 },   { 2, -2, 0, 1, 107, 0 },
};

/// Factor E^|m| of terms containing the Sun's mean anomaly (Meeus eq. 47.6).
double eccentricityFactor(int m, double e)
{
  return m == 0 ? 1.0 : (m == 1 || m == -1 ? e : e * e);
}

}  // namespace

long daysFromCivil(long year, int month, int day)
{
  // Count years from March so that the leap day ends the year; eras of 400 years (146097 days).
  const long y = year - (month <= 2 ? 1 : 0);
  const long era = (y >= 0 ? y : y - 399) / 400;
  const long year_of_era = y - era * 400;                                             // [0, 399]
  const long day_of_year = (153 * (month + (month > 2 ? -3 : 9)) + 2) / 5 + day - 1;  // [0, 365]
  const long day_of_era = year_of_era * 365 + year_of_era / 4 - year_of_era / 100 + day_of_year;
  return era * 146097 + day_of_era - 719468;  // 719468: days from 0000-03-01 to 1970-01-01
}

double parseRunStartUtc(const std::string& text)
{
  const double utc = parseUtc(text);
  if (utc < kRosTimeMinUtc || utc > kRosTimeMaxUtc)
    throw std::invalid_argument(text + " must be between 1970 and 2106 (ROS time)");
  return utc;
}

double parseUtc(const std::string& text)
{
  int year = 0, month = 0, day = 0, hour = 0, minute = 0, consumed = 0;
  double second = 0.0;
  char sep = 0;
  const int n = std::sscanf(text.c_str(), "%4d-%2d-%2d%c%2d:%2d:%lf%n", &year, &month, &day, &sep, &hour, &minute,
                            &second, &consumed);
  if (n < 7 || (sep != 'T' && sep != ' '))
    throw std::invalid_argument("'" + text + "' is not an ISO 8601 UTC time like 2025-06-21T10:30:00Z");
  if (static_cast<std::size_t>(consumed) != text.size() - 1 || text.back() != 'Z')
    throw std::invalid_argument("'" + text + "' must end with 'Z' (UTC), e.g. 2025-06-21T10:30:00Z");
  static const int kDaysInMonth[] = { 31, 29, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31 };
  const bool leap = (year % 4 == 0 && year % 100 != 0) || year % 400 == 0;
  if (month < 1 || month > 12 || day < 1 || day > kDaysInMonth[month - 1] || (month == 2 && day == 29 && !leap))
    throw std::invalid_argument("'" + text + "' is not a calendar date");
  if (hour < 0 || hour > 23 || minute < 0 || minute > 59 || !(second >= 0.0) || second >= 60.0)
    throw std::invalid_argument("'" + text + "' has a time of day outside 00:00:00-23:59:59.999");
  return static_cast<double>(daysFromCivil(year, month, day)) * 86400.0 + hour * 3600.0 + minute * 60.0 + second;
}

std::string formatUtc(double unix_seconds)
{
  const double ms_total = std::round(unix_seconds * 1000.0);  // milliseconds, so 59.9996 s is not printed as 60
  const double days_f = std::floor(ms_total / 86400000.0);
  long long ms = static_cast<long long>(ms_total - days_f * 86400000.0);
  const long z = static_cast<long>(days_f) + 719468;  // days from 0000-03-01
  const long era = (z >= 0 ? z : z - 146096) / 146097;
  const long doe = z - era * 146097;
  const long yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
  const long doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
  const long mp = (5 * doy + 2) / 153;
  const long day = doy - (153 * mp + 2) / 5 + 1;
  const long month = mp < 10 ? mp + 3 : mp - 9;
  const long year = yoe + era * 400 + (month <= 2 ? 1 : 0);
  const long long hour = ms / 3600000;
  ms -= hour * 3600000;
  const long long minute = ms / 60000;
  ms -= minute * 60000;
  std::ostringstream out;
  out << std::setfill('0') << std::setw(4) << year << '-' << std::setw(2) << month << '-' << std::setw(2) << day << 'T'
      << std::setw(2) << hour << ':' << std::setw(2) << minute << ':' << std::setw(2) << ms / 1000 << '.'
      << std::setw(3) << ms % 1000 << 'Z';
  return out.str();
}

double julianDay(double unix_seconds)
{
  return 2440587.5 + unix_seconds / 86400.0;
}

double deltaT(double year)
{
  const double t = year - 2000.0;
  return 62.92 + 0.32217 * t + 0.005589 * t * t;
}

Nutation nutation(double jde)
{
  const double t = (jde - kJ2000) / kDaysPerCentury;
  const double omega = 125.04452 - 1934.136261 * t;  // Moon's ascending node
  const double l_sun = 280.4665 + 36000.7698 * t;    // mean longitudes of Sun and Moon
  const double l_moon = 218.3165 + 481267.8813 * t;
  Nutation n;
  n.longitude = (-17.20 * sinD(omega) - 1.32 * sinD(2 * l_sun) - 0.23 * sinD(2 * l_moon) + 0.21 * sinD(2 * omega)) *
                kArcsecToDeg * kDegToRad;
  n.obliquity = (9.20 * cosD(omega) + 0.57 * cosD(2 * l_sun) + 0.10 * cosD(2 * l_moon) - 0.09 * cosD(2 * omega)) *
                kArcsecToDeg * kDegToRad;
  const double eps0_arcsec = 21.448 - 46.8150 * t - 0.00059 * t * t + 0.001813 * t * t * t;
  n.mean_obliquity = (23.0 + 26.0 / 60.0 + eps0_arcsec * kArcsecToDeg) * kDegToRad;
  return n;
}

Equatorial sunEquatorial(double jde)
{
  const double t = (jde - kJ2000) / kDaysPerCentury;
  const double l0 = 280.46646 + 36000.76983 * t + 0.0003032 * t * t;  // geometric mean longitude
  const double m = 357.52911 + 35999.05029 * t - 0.0001537 * t * t;   // mean anomaly
  const double e = 0.016708634 - 0.000042037 * t - 0.0000001267 * t * t;
  const double c = (1.914602 - 0.004817 * t - 0.000014 * t * t) * sinD(m) + (0.019993 - 0.000101 * t) * sinD(2 * m) +
                   0.000289 * sinD(3 * m);  // equation of the centre
  const double true_longitude = l0 + c;
  const double anomaly = m + c;
  const double radius_au = 1.000001018 * (1.0 - e * e) / (1.0 + e * cosD(anomaly));
  const double omega = 125.04 - 1934.136 * t;
  const double lambda = true_longitude - 0.00569 - 0.00478 * sinD(omega);  // aberration and nutation
  const Nutation nut = nutation(jde);
  const double eps = nut.mean_obliquity + 0.00256 * cosD(omega) * kDegToRad;
  Equatorial out;
  out.longitude = wrapDeg(lambda) * kDegToRad;
  out.latitude = 0.0;
  out.distance_km = radius_au * kAstronomicalUnitKm;
  eclipticToEquatorial(out.longitude, 0.0, eps, out.right_ascension, out.declination);
  return out;
}

Equatorial moonEquatorial(double jde)
{
  const double t = (jde - kJ2000) / kDaysPerCentury;
  const double t2 = t * t, t3 = t2 * t, t4 = t3 * t;
  // Fundamental arguments (Meeus eqs. 47.1-47.5), degrees.
  const double lp = wrapDeg(218.3164477 + 481267.88123421 * t - 0.0015786 * t2 + t3 / 538841.0 - t4 / 65194000.0);
  const double d = wrapDeg(297.8501921 + 445267.1114034 * t - 0.0018819 * t2 + t3 / 545868.0 - t4 / 113065000.0);
  const double m = wrapDeg(357.5291092 + 35999.0502909 * t - 0.0001536 * t2 + t3 / 24490000.0);
  const double mp = wrapDeg(134.9633964 + 477198.8675055 * t + 0.0087414 * t2 + t3 / 69699.0 - t4 / 14712000.0);
  const double f = wrapDeg(93.2720950 + 483202.0175233 * t - 0.0036539 * t2 - t3 / 3526000.0 + t4 / 863310000.0);
  const double a1 = 119.75 + 131.849 * t;
  const double a2 = 53.09 + 479264.290 * t;
  const double a3 = 313.45 + 481266.484 * t;
  const double e = 1.0 - 0.002516 * t - 0.0000074 * t2;

  double sum_l = 0.0, sum_r = 0.0, sum_b = 0.0;
  for (const LunarTerm& term : kLongitudeDistance)
  {
    const double arg = term.d * d + term.m * m + term.mp * mp + term.f * f;
    const double factor = eccentricityFactor(term.m, e);
    sum_l += term.sine * factor * sinD(arg);
    sum_r += term.cosine * factor * cosD(arg);
  }
  for (const LunarTerm& term : kLatitude)
  {
    const double arg = term.d * d + term.m * m + term.mp * mp + term.f * f;
    sum_b += term.sine * eccentricityFactor(term.m, e) * sinD(arg);
  }
  // Venus (A1), Jupiter (A2) and the Earth's flattening (L' terms).
  sum_l += 3958.0 * sinD(a1) + 1962.0 * sinD(lp - f) + 318.0 * sinD(a2);
  sum_b += -2235.0 * sinD(lp) + 382.0 * sinD(a3) + 175.0 * sinD(a1 - f) + 175.0 * sinD(a1 + f) + 127.0 * sinD(lp - mp) -
           115.0 * sinD(lp + mp);

  const Nutation nut = nutation(jde);
  Equatorial out;
  out.longitude = wrapRad((lp + sum_l * 1e-6) * kDegToRad + nut.longitude);
  out.latitude = sum_b * 1e-6 * kDegToRad;
  out.distance_km = 385000.56 + sum_r / 1000.0;
  eclipticToEquatorial(out.longitude, out.latitude, nut.true_obliquity(), out.right_ascension, out.declination);
  return out;
}

double apparentSiderealTime(double jd_ut)
{
  const double t = (jd_ut - kJ2000) / kDaysPerCentury;
  const double mean_deg =
      280.46061837 + 360.98564736629 * (jd_ut - kJ2000) + 0.000387933 * t * t - t * t * t / 38710000.0;
  const Nutation nut = nutation(jd_ut);  // UT vs TT: < 1e-7 deg here
  return wrapRad(wrapDeg(mean_deg) * kDegToRad + nut.longitude * std::cos(nut.true_obliquity()));
}

double refraction(double elevation, const Atmosphere& air)
{
  const double scale = (air.pressure_hpa / 1010.0) * (283.0 / air.temperature_k);
  auto saemundsson = [](double h_deg) {  // arcmin, h = true elevation in degrees
    return 1.02 / std::tan((h_deg + 10.3 / (h_deg + 5.11)) * kDegToRad);
  };
  const double h = elevation * kRadToDeg;
  double arcmin;
  if (h >= -1.0)
    arcmin = saemundsson(std::min(h, 90.0));
  else
    arcmin = saemundsson(-1.0) * std::max(0.0, (h + 3.0) / 2.0);
  return scale * arcmin / 60.0 * kDegToRad;
}

Horizontal toHorizontal(const Equatorial& body, double gast, const Site& site, const Atmosphere& air)
{
  // Body and observer in the Earth-fixed frame (x to Greenwich on the equator, z to the pole), km.
  const double hour_angle_greenwich = gast - body.right_ascension;
  const double cd = std::cos(body.declination);
  const double bx = body.distance_km * cd * std::cos(hour_angle_greenwich);
  const double by = -body.distance_km * cd * std::sin(hour_angle_greenwich);
  const double bz = body.distance_km * std::sin(body.declination);

  // The observer on the WGS-84 ellipsoid (GeographicLib::Geocentric, m), and the rotation M
  // from the east-north-up axes there to the Earth-fixed ones: the body's direction in ENU is
  // M^T (body - observer).
  double ox = 0.0, oy = 0.0, oz = 0.0;
  std::vector<double> m(9);  // row-major
  GeographicLib::Geocentric::WGS84().Forward(site.latitude_deg, site.longitude_deg, site.altitude_m, ox, oy, oz, m);
  const double dx = bx - ox / 1000.0, dy = by - oy / 1000.0, dz = bz - oz / 1000.0;  // km
  const double east = m[0] * dx + m[3] * dy + m[6] * dz;
  const double north = m[1] * dx + m[4] * dy + m[7] * dz;
  const double up = m[2] * dx + m[5] * dy + m[8] * dz;

  Horizontal out;
  out.azimuth = wrapRad(std::atan2(east, north));
  out.geometric_elevation = std::atan2(up, std::hypot(east, north));
  out.elevation = out.geometric_elevation + refraction(out.geometric_elevation, air);
  const double ce = std::cos(out.elevation);
  out.direction = { ce * std::sin(out.azimuth), ce * std::cos(out.azimuth), std::sin(out.elevation) };
  return out;
}

double moonPhaseAngle(const Equatorial& sun, const Equatorial& moon)
{
  // Geocentric elongation psi (Meeus 48.2), then the phase angle i (48.3).
  const double cos_psi =
      std::sin(sun.declination) * std::sin(moon.declination) +
      std::cos(sun.declination) * std::cos(moon.declination) * std::cos(sun.right_ascension - moon.right_ascension);
  const double psi = std::acos(std::max(-1.0, std::min(1.0, cos_psi)));
  return std::atan2(sun.distance_km * std::sin(psi), moon.distance_km - sun.distance_km * std::cos(psi));
}

SkyState skyAt(double utc, const Site& site, const Atmosphere& air)
{
  const double jd = julianDay(utc);
  const double year = 1970.0 + utc / (365.2425 * 86400.0);
  const double jde = jd + deltaT(year) / 86400.0;
  const double gast = apparentSiderealTime(jd);
  SkyState sky;
  sky.sun_equatorial = sunEquatorial(jde);
  sky.moon_equatorial = moonEquatorial(jde);
  sky.sun = toHorizontal(sky.sun_equatorial, gast, site, air);
  sky.moon = toHorizontal(sky.moon_equatorial, gast, site, air);
  sky.moon_phase_angle = moonPhaseAngle(sky.sun_equatorial, sky.moon_equatorial);
  sky.moon_illumination = 0.5 * (1.0 + std::cos(sky.moon_phase_angle));
  return sky;
}

}  // namespace environment
}  // namespace avsp
