#pragma once
/**
 * @file astronomy.hpp
 * @brief Sun and Moon positions for the environment node (docs/MODELS.md section 6), no ROS.
 *
 * Time: UTC as seconds since 1970-01-01 (Unix time, leap seconds ignored, UT1 = UTC: at
 * most 0.9 s, 0.004 deg of hour angle). Dynamical time TT = UT + deltaT(year).
 *
 * Sun: the low-accuracy solar coordinates of J. Meeus, *Astronomical Algorithms* (2nd ed.,
 * 1998), chapter 25 (the algorithm behind NOAA's Solar Calculator): geometric mean
 * longitude and anomaly, equation of the centre, aberration and nutation in longitude,
 * true obliquity; accurate to 0.01 deg in right ascension and declination. Sidereal time
 * from Meeus eq. 12.4 with the equation of the equinoxes (nutation, chapter 22's
 * low-precision terms). Azimuth and elevation are topocentric (WGS-84 observer).
 *
 * Moon: Meeus chapter 47 (ELP-2000/82 truncated to the 60 + 60 periodic terms of his
 * tables 47.A and 47.B, with the additive Venus/Jupiter/flattening terms): about 10" in
 * longitude and 4" in latitude; topocentric parallax applied exactly (vector difference).
 * Illuminated fraction from the geocentric elongation (Meeus chapter 48).
 */
#include <array>
#include <string>

namespace avsp
{
namespace environment
{
constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;
constexpr double kRadToDeg = 180.0 / kPi;
constexpr double kAstronomicalUnitKm = 149597870.7;

/// Observer on the WGS-84 ellipsoid.
struct Site
{
  double latitude_deg = 0.0;   ///< [-90, 90], positive north
  double longitude_deg = 0.0;  ///< [-180, 360), positive east
  double altitude_m = 0.0;     ///< m above the ellipsoid
};

/// Air at the observer, for refraction.
struct Atmosphere
{
  double pressure_hpa = 1010.0;   ///< hPa, station pressure
  double temperature_k = 283.15;  ///< K
};

/**
 * @brief Parses an ISO 8601 UTC time "YYYY-MM-DDTHH:MM:SS[.fff]Z" (the 'Z' is required,
 *        'T' may be a space) into Unix seconds.
 * @throw std::invalid_argument saying what is wrong with the text
 */
double parseUtc(const std::string& text);

/// Unix seconds ros::Time can hold: [0, 2^32 - 1], 1970-01-01 .. 2106-02-07 (the model itself
/// accepts 1800-2200; a run's clock is ROS time).
constexpr double kRosTimeMinUtc = 0.0;
constexpr double kRosTimeMaxUtc = 4294967295.0;

/**
 * @brief parseUtc(), then the ROS time range: what a run's start time may be.
 * @throw std::invalid_argument saying what is wrong with the text, or "... must be between 1970
 *        and 2106 (ROS time)"
 */
double parseRunStartUtc(const std::string& text);

/// Formats Unix seconds as "YYYY-MM-DDTHH:MM:SS.sssZ".
std::string formatUtc(double unix_seconds);

/// Days from 1970-01-01 to the proleptic Gregorian date (year, month 1..12, day 1..31).
long daysFromCivil(long year, int month, int day);

/// Julian Day (UT) of Unix seconds: 2440587.5 + s / 86400.
double julianDay(double unix_seconds);

/**
 * @brief TT - UT (s) for a decimal year: Espenak & Meeus' polynomial for 2005-2050
 *        (62.92 + 0.32217 t + 0.005589 t^2, t = year - 2000), applied to every year. Off by
 *        less than 1 min over 1960-2100, which moves the Moon by < 0.01 deg.
 */
double deltaT(double year);

/// Nutation (Meeus chapter 22, low precision: 0.5" in longitude, 0.1" in obliquity).
struct Nutation
{
  double longitude = 0.0;       ///< rad, delta psi
  double obliquity = 0.0;       ///< rad, delta epsilon
  double mean_obliquity = 0.0;  ///< rad, epsilon_0 (Meeus eq. 22.2)
  double true_obliquity() const { return mean_obliquity + obliquity; }
};

/// Nutation and obliquity at Julian Ephemeris Day `jde`.
Nutation nutation(double jde);

/// Apparent geocentric position of a body, true equator and equinox of date.
struct Equatorial
{
  double right_ascension = 0.0;  ///< rad, [0, 2 pi)
  double declination = 0.0;      ///< rad
  double distance_km = 0.0;      ///< km from the Earth's centre
  double longitude = 0.0;        ///< rad, apparent ecliptic longitude of date, [0, 2 pi)
  double latitude = 0.0;         ///< rad, ecliptic latitude
};

/**
 * @brief The Sun at Julian Ephemeris Day `jde` (Meeus chapter 25, low accuracy):
 *        Example 25.a (1992 Oct 13.0 TD) gives RA 198.38083 deg, Dec -7.78507 deg.
 */
Equatorial sunEquatorial(double jde);

/**
 * @brief The Moon at Julian Ephemeris Day `jde` (Meeus chapter 47, truncated ELP-2000/82):
 *        Example 47.a (1992 Apr 12.0 TD) gives RA 134.688470 deg, Dec 13.768368 deg,
 *        distance 368409.7 km.
 */
Equatorial moonEquatorial(double jde);

/// Greenwich apparent sidereal time (rad, [0, 2 pi)) at Julian Day `jd_ut` (UT) (Meeus 12.4 + Δψ cos ε).
double apparentSiderealTime(double jd_ut);

/// A body seen from a site.
struct Horizontal
{
  double azimuth = 0.0;               ///< rad, clockwise from true north, [0, 2 pi)
  double elevation = 0.0;             ///< rad, apparent: geometric + refraction
  double geometric_elevation = 0.0;   ///< rad, topocentric, no refraction (airless)
  std::array<double, 3> direction{};  ///< unit vector towards the body (apparent), local ENU (x east, y north, z up)
};

/**
 * @brief Topocentric azimuth and elevation of a body at geocentric `body` (its distance
 *        gives the parallax) for the site, at Greenwich apparent sidereal time `gast` (rad).
 */
Horizontal toHorizontal(const Equatorial& body, double gast, const Site& site, const Atmosphere& air);

/**
 * @brief Atmospheric refraction (rad) to add to a geometric elevation `elevation` (rad):
 *        Saemundsson's formula (Meeus eq. 16.4) scaled by (P / 1010 hPa)(283 K / T). Below
 *        -1 deg it fades linearly to 0 at -3 deg (the formula is meant for the visible sky).
 */
double refraction(double elevation, const Atmosphere& air);

/// Sun and Moon seen from a site at one instant.
struct SkyState
{
  Horizontal sun;
  Horizontal moon;
  Equatorial sun_equatorial;
  Equatorial moon_equatorial;
  double moon_phase_angle = 0.0;   ///< rad, Sun-Moon-Earth angle: 0 full, pi new
  double moon_illumination = 0.0;  ///< [0, 1], illuminated fraction of the disc (Meeus 48.1)
};

/// The sky at Unix time `utc` for the site (throws nothing; any finite input works).
SkyState skyAt(double utc, const Site& site, const Atmosphere& air);

/// Illuminated fraction of the Moon and phase angle (rad) from geocentric Sun and Moon (Meeus chapter 48).
double moonPhaseAngle(const Equatorial& sun, const Equatorial& moon);

}  // namespace environment
}  // namespace avsp
