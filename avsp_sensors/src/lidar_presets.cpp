// Lidar presets from manufacturers' manuals, data sheets and the public ROS drivers'
// calibration files (README.md, "Lidar presets", lists every figure and its source).
#include <cmath>
#include <stdexcept>
#include <string>

#include "avsp_sensors/lidar.hpp"

namespace avsp
{
namespace sensors
{
namespace
{
constexpr double kDeg = 3.14159265358979323846 / 180.0;

/// VLP-16 (Velodyne VLP-16 User Manual 63-9243 Rev D; ros-drivers/velodyne VLP16db.yaml):
/// laser IDs 0-15 fire in order every 2.304 us, the sequence repeats every 55.296 us.
LidarConfig vlp16()
{
  LidarConfig c;
  c.name = "VLP-16";
  const double elevation_deg[16] = { -15, 1, -13, 3, -11, 5, -9, 7, -7, 9, -5, 11, -3, 13, -1, 15 };
  for (int id = 0; id < 16; ++id)
    c.channels.push_back({ elevation_deg[id] * kDeg, 0.0, id * 2.304e-6 });
  c.rotation_rate = 10.0;
  c.columns = 1808;  // 0.1 s / 55.296 us = 1808.4 firing cycles per revolution at 600 rpm
  c.clockwise = true;
  c.min_range = 0.5;
  c.max_range = 100.0;
  c.reference_range = 100.0;
  c.reference_reflectivity = 0.8;
  c.range_noise = 0.03;  // "up to +-3 cm (typical)" taken as one standard deviation
  c.divergence_horizontal = 3.0e-3;
  c.divergence_vertical = 1.5e-3;
  c.aperture_radius = 0.005;
  c.wavelength = 903e-9;
  return c;
}

/// HDL-32E (ros-drivers/velodyne 32db.yaml; HDL-32E manual): laser IDs 0-31 fire in order
/// every 1.152 us, the sequence (with its recharge) repeats every 46.08 us.
LidarConfig hdl32e()
{
  LidarConfig c;
  c.name = "HDL-32E";
  const double elevation_deg[32] = { -30.67, -9.33, -29.33, -8.00, -28.00, -6.67, -26.67, -5.33,
                                     -25.33, -4.00, -24.00, -2.67, -22.67, -1.33, -21.33, 0.00,
                                     -20.00, 1.33,  -18.67, 2.67,  -17.33, 4.00,  -16.00, 5.33,
                                     -14.67, 6.67,  -13.33, 8.00,  -12.00, 9.33,  -10.67, 10.67 };
  for (int id = 0; id < 32; ++id)
    c.channels.push_back({ elevation_deg[id] * kDeg, 0.0, id * 1.152e-6 });
  c.rotation_rate = 10.0;
  c.columns = 2170;  // 0.1 s / 46.08 us = 2170.1: 0.166 deg azimuth steps, ~694,000 points/s
  c.clockwise = true;
  c.min_range = 0.05;
  c.max_range = 100.0;
  c.reference_range = 100.0;
  c.reference_reflectivity = 0.8;
  c.range_noise = 0.02;  // "< 2 cm" accuracy
  c.divergence_horizontal = 3.0e-3;
  c.divergence_vertical = 1.5e-3;
  c.aperture_radius = 0.005;
  c.wavelength = 905e-9;
  return c;
}

/// HDL-64E S3: one unit's calibration in ros-drivers/velodyne (params/64e_s3-xiesc.yaml),
/// vert_correction and rot_correction (rad) for laser IDs 0-63; upper and lower blocks fire
/// together (no per-laser offsets modelled).
LidarConfig hdl64e()
{
  LidarConfig c;
  c.name = "HDL-64E";
  const double rot[64] = {
    -0.07648247457737148,  -0.03932070772308096,  0.06005350008746038,   0.09919490315516696,    -0.00095355016485159,
    0.03824387099052699,   -0.015297255529962315, 0.024255809272700053,  0.07354442571180776,    0.11317857886058363,
    0.05954228616823424,   0.09906092120980835,   -0.07574798243226695,  -0.037047761947550245,  -0.0895955468906376,
    -0.05072966149865084,  -0.001864320564407547, 0.03747852840556422,   -0.015194972429011364,  0.02391977928648433,
    0.07264374331532833,   0.11143265968730214,   0.05942554283989759,   0.09797042203986979,    -0.07658879305408597,
    -0.0379098725675606,   -0.0904730670226138,   -0.051308328902808065, -0.0019143155208309244, 0.03681404490741569,
    -0.015542064486559148, 0.023284423588222334,  -0.1278634161583795,   -0.066528586091226,     0.08854290740283328,
    0.14547956884148489,   -0.005071588212420635, 0.05427589303135225,   -0.028143856558087547,  0.03172272051181349,
    0.11411698480351568,   0.1735498527902839,    0.09564756333839054,   0.15538288292189534,    -0.12413605610123538,
    -0.06413447432303407,  -0.14872602785785152,  -0.08707280959256145,  -0.006799911150716457,  0.05242808851765633,
    -0.028383715411859876, 0.031843273893907245,  0.10955275158734502,   0.16876716543828738,    0.09037283276367176,
    0.14871534295217081,   -0.12100867217308608,  -0.06431965899265843,  -0.14486168214370612,   -0.0852480451703211,
    -0.005967226432828876, 0.050600613599087636,  -0.027436902217920986, 0.0290479702718764,
  };
  const double vert[64] = {
    -0.1261818455292898,   -0.11953745909742221,   0.00356118725906175,   0.010306535403103584,  -0.1144967440141401,
    -0.10803612329921503,  -0.14944538101702426,   -0.14344353231329066,  -0.10278016723125998,  -0.09569590023202451,
    -0.1386345201601863,   -0.13181073657049397,   -0.054438932963427306, -0.048730533448148504, -0.08961595328025192,
    -0.0839353306800186,   -0.043427018903405855,  -0.03648801216715539,  -0.07906187922560139,  -0.07255814015150577,
    -0.031587736747464255, -0.025460288914769372,  -0.06665878416276627,  -0.06055112836378901,  0.015620435355027301,
    0.022567997346205196,  -0.019943931467746017,  -0.013200099491225388, 0.027266617424120905,  0.03421014630846329,
    -0.007885903531460533, -0.0015491891506552067, -0.39021216204755743,  -0.38355018793281753,  -0.197138848550284,
    -0.18768579625563228,  -0.3750836655445631,    -0.36762882325722723,  -0.4285668719175616,   -0.4214410765541042,
    -0.3565455112681652,   -0.34717860842539194,   -0.4110102035460227,   -0.40083030888437793,  -0.2840315837972709,
    -0.27761533458791926,  -0.3359268721635124,    -0.33026751989087316,  -0.26851710773019805,  -0.26051854302098837,
    -0.3216451745070007,   -0.3135280670349956,    -0.24941678290173272,  -0.2409525119882134,   -0.30313513748485243,
    -0.29323634555253386,  -0.17760463486977288,   -0.17006926832673774,  -0.22974121500510264,  -0.22391891879349718,
    -0.16231529056824404,  -0.15314424682880032,   -0.21457119711920336,  -0.2079266762969834,
  };
  // The driver turns a laser's reading at encoder azimuth a (clockwise) into the direction
  // a - rot_correction clockwise, i.e. rot_correction counter-clockwise: our azimuth_offset.
  for (int id = 0; id < 64; ++id)
    c.channels.push_back({ vert[id], rot[id], 0.0 });
  c.rotation_rate = 10.0;
  c.columns = 2083;  // 1.333 M points/s / 64 lasers / 10 Hz
  c.clockwise = true;
  c.min_range = 1.0;
  c.max_range = 120.0;
  c.reference_range = 120.0;  // "120 m for cars and foliage (~80 % reflectivity)"
  c.reference_reflectivity = 0.8;
  c.range_noise = 0.02;  // "< 2 cm" accuracy
  c.divergence_horizontal = 3.0e-3;
  c.divergence_vertical = 1.5e-3;
  c.aperture_radius = 0.005;
  c.wavelength = 905e-9;
  return c;
}

/// Ouster OS1-64, first generation: the SDK's default (gen1) beam intrinsics, the OS1 data
/// sheet's 0.8-120 m range at 80 % reflectivity, 850 nm, 0.13 deg divergence, 10 mm beam.
LidarConfig os1_64()
{
  LidarConfig c;
  c.name = "OS1-64";
  const double altitude_deg[64] = {
    16.611,  16.084,  15.557,  15.029,  14.502,  13.975,  13.447,  12.920,  12.393,  11.865,  11.338,  10.811,  10.283,
    9.756,   9.229,   8.701,   8.174,   7.646,   7.119,   6.592,   6.064,   5.537,   5.010,   4.482,   3.955,   3.428,
    2.900,   2.373,   1.846,   1.318,   0.791,   0.264,   -0.264,  -0.791,  -1.318,  -1.846,  -2.373,  -2.900,  -3.428,
    -3.955,  -4.482,  -5.010,  -5.537,  -6.064,  -6.592,  -7.119,  -7.646,  -8.174,  -8.701,  -9.229,  -9.756,  -10.283,
    -10.811, -11.338, -11.865, -12.393, -12.920, -13.447, -13.975, -14.502, -15.029, -15.557, -16.084, -16.611,
  };
  const double azimuth_deg[4] = { 3.164, 1.055, -1.055, -3.164 };
  // Ouster's XYZ formula uses theta = theta_encoder - 2 pi beam_azimuth / 360, so the beam
  // azimuth angle enters with a minus sign.
  for (int k = 0; k < 64; ++k)
    c.channels.push_back({ altitude_deg[k] * kDeg, -azimuth_deg[k % 4] * kDeg, 0.0 });
  c.rotation_rate = 10.0;
  c.columns = 1024;    // the default lidar_mode 1024x10
  c.clockwise = true;  // theta_encoder = 2 pi (1 - measurement_id / scan_width)
  c.min_range = 0.8;
  c.max_range = 120.0;
  c.reference_range = 120.0;
  c.reference_reflectivity = 0.8;
  c.range_noise = 0.03;  // range repeatability +-3 cm at SNR 100
  c.divergence_horizontal = 0.13 * kDeg;
  c.divergence_vertical = 0.13 * kDeg;
  c.aperture_radius = 0.005;
  c.wavelength = 850e-9;
  return c;
}
}  // namespace

std::vector<std::string> lidarPresetNames()
{
  return { "VLP-16", "HDL-32E", "HDL-64E", "OS1-64" };
}

LidarConfig lidarPreset(const std::string& name)
{
  if (name == "VLP-16")
    return vlp16();
  if (name == "HDL-32E")
    return hdl32e();
  if (name == "HDL-64E")
    return hdl64e();
  if (name == "OS1-64")
    return os1_64();
  std::string known;
  for (const std::string& n : lidarPresetNames())
    known += (known.empty() ? "" : ", ") + n;
  throw std::invalid_argument("lidarPreset: unknown preset '" + name + "' (known: " + known + ")");
}

}  // namespace sensors
}  // namespace avsp
