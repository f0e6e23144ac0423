#include "avsp_sensors/camera.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "avsp_sensors/parallel.hpp"
#include "avsp_sensors/random.hpp"
#include "avsp_terrain/terrain_objects.hpp"

namespace avsp
{
namespace sensors
{
namespace
{
constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

float luminance(const Eigen::Vector3f& c)
{
  return 0.2126f * c.x() + 0.7152f * c.y() + 0.0722f * c.z();
}
Eigen::Vector3f normalised(const Eigen::Vector3f& c)
{
  return c / luminance(c);
}
double clamp01(double x)
{
  return std::min(1.0, std::max(0.0, x));
}

/// Kasten-Young relative air mass at elevation h (deg, > -6).
double airMass(double h_deg)
{
  return 1.0 / (std::sin(h_deg * kDeg) + 0.50572 * std::pow(h_deg + 6.07995, -1.6364));
}

std::uint8_t objectClass(terrain::ObjectType type)
{
  switch (type)
  {
    case terrain::ObjectType::kTree:
    case terrain::ObjectType::kShrub:
    case terrain::ObjectType::kGrass:
      return kClassVegetation;
    case terrain::ObjectType::kRock:
      return kClassRock;
    case terrain::ObjectType::kPole:
      return kClassPole;
    case terrain::ObjectType::kFence:
      return kClassFence;
    case terrain::ObjectType::kBarrier:
      return kClassBarrier;
    case terrain::ObjectType::kBuilding:
      return kClassBuilding;
  }
  return kClassUnknown;
}

/// Linear RGB albedo of a class (terrain classes are the soil's, handled by the caller).
Eigen::Vector3f classAlbedo(std::uint8_t cls, Season season)
{
  switch (cls)
  {
    case kClassVegetation:
      switch (season)
      {
        case Season::kSpring:
          return { 0.18f, 0.40f, 0.10f };
        case Season::kSummer:
          return { 0.08f, 0.25f, 0.05f };
        case Season::kFall:
          return { 0.45f, 0.25f, 0.06f };
        case Season::kWinter:
          return { 0.25f, 0.22f, 0.18f };  // bare branches
      }
      break;
    case kClassRock:
      return { 0.35f, 0.33f, 0.30f };
    case kClassPole:
      return { 0.35f, 0.25f, 0.15f };
    case kClassFence:
      return { 0.45f, 0.45f, 0.45f };
    case kClassBarrier:
      return { 0.55f, 0.55f, 0.52f };
    case kClassBuilding:
      return { 0.50f, 0.42f, 0.35f };
    case kClassVehicle:
      return { 0.25f, 0.30f, 0.20f };
    case kClassPerson:
      return { 0.35f, 0.28f, 0.22f };
    case kClassAnimal:
      return { 0.40f, 0.28f, 0.16f };
    default:
      break;
  }
  return { 0.5f, 0.5f, 0.5f };
}

/// Heat balance of a surface (README, "Thermal"): solar gain over a convective coefficient.
double convectiveCoefficient(std::uint8_t cls)
{
  return cls == kClassVegetation ? 100.0 : 25.0;  // W/m^2/K; vegetation: transpiration cools
}

const Eigen::Vector3f kSnowAlbedo(0.85f, 0.87f, 0.90f);
}  // namespace

Season seasonOf(int month, double latitude_deg)
{
  const int m = ((month - 1) % 12 + 12) % 12 + 1;
  int s = (m == 12 || m <= 2) ? 3 : (m <= 5 ? 0 : (m <= 8 ? 1 : 2));  // winter, spring, summer, fall
  if (latitude_deg < 0.0)
    s = (s + 2) % 4;
  return static_cast<Season>(s);
}

Eigen::Vector3f soilAlbedo(const std::string& name)
{
  if (name == "asphalt")
    return { 0.08f, 0.08f, 0.085f };
  if (name == "gravel")
    return { 0.35f, 0.33f, 0.30f };
  if (name == "dry_sand")
    return { 0.55f, 0.47f, 0.35f };
  if (name == "sandy_loam")
    return { 0.35f, 0.28f, 0.20f };
  if (name == "clay")
    return { 0.40f, 0.28f, 0.20f };
  if (name == "mud")
    return { 0.20f, 0.16f, 0.12f };
  if (name == "snow")
    return kSnowAlbedo;
  if (name == "grass_over_loam")
    return { 0.12f, 0.30f, 0.08f };
  return { 0.30f, 0.27f, 0.22f };
}

// ---- materials ---------------------------------------------------------------------------
CameraMaterials::CameraMaterials()
{
  setSoils({ SoilLook() }, {});
}

void CameraMaterials::setSoils(std::vector<SoilLook> palette, std::vector<std::uint8_t> soil_map)
{
  if (palette.empty() || palette.size() > 200)
    throw std::invalid_argument("CameraMaterials::setSoils: palette must have 1 to 200 soils, got " +
                                std::to_string(palette.size()));
  std::vector<std::uint8_t> classes;
  for (std::size_t k = 0; k < palette.size(); ++k)
  {
    const SoilLook& s = palette[k];
    if (!(s.wetness >= 0.f && s.wetness <= 1.f))
      throw std::invalid_argument("CameraMaterials::setSoils: palette[" + std::to_string(k) +
                                  "].wetness must be in [0, 1]");
    if (!(s.albedo.minCoeff() >= 0.f && s.albedo.maxCoeff() <= 1.f))
      throw std::invalid_argument("CameraMaterials::setSoils: palette[" + std::to_string(k) +
                                  "].albedo must be in [0, 1]");
    classes.push_back(s.name == "asphalt" ? static_cast<std::uint8_t>(kClassRoad)
                                          : static_cast<std::uint8_t>(kClassSoilBase + k));
  }
  for (std::size_t k = 0; k < soil_map.size(); ++k)
    if (soil_map[k] >= palette.size())
      throw std::invalid_argument("CameraMaterials::setSoils: soil_map[" + std::to_string(k) +
                                  "] = " + std::to_string(soil_map[k]) + " is not in the palette");
  soils_ = std::move(palette);
  soil_map_ = std::move(soil_map);
  soil_class_ = std::move(classes);
}

void CameraMaterials::setObjects(const terrain::ObjectSet& objects)
{
  object_class_.clear();
  for (const terrain::TerrainObject& o : objects.all())
    object_class_[o.id] = objectClass(o.type);
}

void CameraMaterials::setBody(std::uint32_t id, std::uint8_t semantic_class, double temperature)
{
  if (!std::isnan(temperature) && !(temperature > 0.0 && std::isfinite(temperature)))
    throw std::invalid_argument("CameraMaterials::setBody: body " + std::to_string(id) +
                                ": temperature must be > 0 K or NaN");
  bodies_[id] = BodyLook{ semantic_class, temperature };
}

double CameraMaterials::bodyTemperature(std::uint32_t id) const
{
  const auto it = bodies_.find(id);
  return it == bodies_.end() ? std::numeric_limits<double>::quiet_NaN() : it->second.temperature;
}

std::size_t CameraMaterials::soilAt(const HeightField& terrain, double x, double y) const
{
  if (soil_map_.empty())
    return 0;
  const double fi = std::round((x - terrain.originX()) / terrain.dx());
  const double fj = std::round((y - terrain.originY()) / terrain.dy());
  const std::size_t i =
      static_cast<std::size_t>(std::min(std::max(fi, 0.0), static_cast<double>(terrain.columns() - 1)));
  const std::size_t j = static_cast<std::size_t>(std::min(std::max(fj, 0.0), static_cast<double>(terrain.rows() - 1)));
  const std::size_t k = j * terrain.columns() + i;
  return k < soil_map_.size() ? soil_map_[k] : 0;
}

std::uint8_t CameraMaterials::classOf(const RayHit& hit, const HeightField& terrain) const
{
  switch (hit.kind)
  {
    case HitKind::kNone:
      return kClassNone;
    case HitKind::kTerrain:
      return soil_class_[soilAt(terrain, hit.point.x(), hit.point.y())];
    case HitKind::kObject:
    {
      const auto it = object_class_.find(hit.id);
      return it == object_class_.end() ? static_cast<std::uint8_t>(kClassUnknown) : it->second;
    }
    case HitKind::kBody:
    {
      const auto it = bodies_.find(hit.id);
      return it == bodies_.end() ? static_cast<std::uint8_t>(kClassVehicle) : it->second.cls;
    }
  }
  return kClassUnknown;
}

std::vector<ClassEntry> CameraMaterials::classTable() const
{
  std::vector<ClassEntry> t{ { kClassNone, "sky" },        { kClassTerrain, "terrain" },
                             { kClassRoad, "road" },       { kClassVegetation, "vegetation" },
                             { kClassRock, "rock" },       { kClassBuilding, "building" },
                             { kClassBarrier, "barrier" }, { kClassFence, "fence" },
                             { kClassVehicle, "vehicle" }, { kClassPerson, "person" },
                             { kClassAnimal, "animal" },   { kClassPole, "pole" } };
  for (std::size_t k = 0; k < soils_.size(); ++k)
    if (soil_class_[k] != kClassRoad)
      t.push_back({ soil_class_[k], "terrain/" + soils_[k].name });
  t.push_back({ kClassUnknown, "unknown" });
  return t;
}

// ---- sky ---------------------------------------------------------------------------------
void validateCameraEnvironment(const CameraEnvironment& env)
{
  auto unit = [](const Eigen::Vector3d& v, const char* name) {
    if (!v.allFinite() || std::abs(v.norm() - 1.0) > 1e-3)
      throw std::invalid_argument(std::string("CameraEnvironment: ") + name + " must be a finite unit vector");
  };
  unit(env.sun_direction, "sun_direction");
  unit(env.moon_direction, "moon_direction");
  auto finite = [](double x, const char* name) {
    if (!std::isfinite(x))
      throw std::invalid_argument(std::string("CameraEnvironment: ") + name + " must be finite");
  };
  finite(env.sun_elevation, "sun_elevation");
  finite(env.moon_elevation, "moon_elevation");
  if (!(env.moon_illumination >= 0.0 && env.moon_illumination <= 1.0))
    throw std::invalid_argument("CameraEnvironment: moon_illumination must be in [0, 1]");
  if (!(env.air_temperature > 0.0 && std::isfinite(env.air_temperature)))
    throw std::invalid_argument("CameraEnvironment: air_temperature must be > 0 K");
  if (!(env.snow_cover >= 0.0 && env.snow_cover <= 1.0))
    throw std::invalid_argument("CameraEnvironment: snow_cover must be in [0, 1]");
  if (!(env.surface_wetness >= 0.0 && env.surface_wetness <= 1.0))
    throw std::invalid_argument("CameraEnvironment: surface_wetness must be in [0, 1]");
  validateWeather(env.weather);
}

SkyLight skyLight(const CameraEnvironment& env)
{
  SkyLight s;
  const double h = env.sun_elevation / kDeg;
  // Direct beam: extraterrestrial 128 klx through the clear air mass (extinction 0.21 per air mass).
  if (h > 0.0)
    s.sun_normal = 128000.0 * std::exp(-0.21 * airMass(h));
  // Diffuse sky on a horizontal surface: clear sky 0.8 + 15.5 sqrt(sin h) klx by day; twilight
  // falls ~0.41 decades per degree below the horizon (800 lx at 0 deg, ~3 lx at -6 deg,
  // ~0.01 lx at -12 deg); starlight and airglow 1 mlx floor.
  if (h > 0.0)
    s.sky_horizontal = 800.0 + 15500.0 * std::sqrt(std::sin(h * kDeg));
  else
    s.sky_horizontal = 800.0 * std::pow(10.0, 0.41 * std::max(h, -30.0));
  s.sky_horizontal = std::max(s.sky_horizontal, 1e-3);
  const double hm = env.moon_elevation / kDeg;
  if (hm > 0.0)
  {
    // Full moon overhead ~0.3 lx; scaled by the lit fraction of its disc.
    s.moon_normal = 0.32 * env.moon_illumination * std::exp(-0.21 * (airMass(hm) - 1.0));
    s.sky_horizontal += 0.1 * s.moon_normal * std::sin(env.moon_elevation);  // moonlit sky
  }
  s.horizontal_total = s.sun_normal * std::max(0.0, std::sin(env.sun_elevation)) + s.sky_horizontal +
                       s.moon_normal * std::max(0.0, std::sin(env.moon_elevation));
  // Colours: day blue, twilight orange at the horizon, night dark blue; fog and haze grey.
  const Eigen::Vector3f day_zenith(0.30f, 0.50f, 1.00f), day_horizon(0.70f, 0.80f, 0.95f);
  const Eigen::Vector3f dusk_zenith(0.35f, 0.40f, 0.75f), dusk_horizon(1.00f, 0.55f, 0.30f);
  const Eigen::Vector3f night(0.25f, 0.30f, 0.55f), grey(0.80f, 0.80f, 0.80f);
  const float twilight = static_cast<float>(clamp01(1.0 - std::abs(h) / 10.0));
  const float dark = static_cast<float>(clamp01((-h - 6.0) / 6.0));
  const double v = env.weather.fog_visibility;
  const float haze = static_cast<float>(std::isfinite(v) ? clamp01(1.0 - v / 10000.0) : 0.0);
  auto mix = [&](const Eigen::Vector3f& day, const Eigen::Vector3f& dusk) {
    Eigen::Vector3f c = normalised(day) * (1.f - twilight) + normalised(dusk) * twilight;
    c = c * (1.f - dark) + normalised(night) * dark;
    c = c * (1.f - haze) + normalised(grey) * haze;
    return normalised(c);
  };
  s.sky_zenith = mix(day_zenith, dusk_zenith);
  s.sky_horizon = mix(day_horizon, dusk_horizon);
  return s;
}

// ---- configuration -----------------------------------------------------------------------
void validateCameraConfig(const CameraConfig& c)
{
  auto fail = [&](const std::string& what) { throw std::invalid_argument("CameraConfig '" + c.name + "': " + what); };
  if (c.width < 1 || c.width > 8192)
    fail("width must be in [1, 8192], got " + std::to_string(c.width));
  if (c.height < 1 || c.height > 8192)
    fail("height must be in [1, 8192], got " + std::to_string(c.height));
  const double max_fov = c.projection == CameraProjection::kPinhole ? kPi * 179.0 / 180.0 : 2.0 * kPi;
  if (!(c.hfov > 0.0 && c.hfov <= max_fov))
    fail(std::string("hfov must be in (0, ") + (c.projection == CameraProjection::kPinhole ? "179 deg" : "360 deg") +
         "], got " + std::to_string(c.hfov) + " rad");
  if (!(c.rate > 0.0 && std::isfinite(c.rate)))
    fail("rate must be finite and > 0 Hz");
  for (double d : c.distortion)
    if (!std::isfinite(d))
      fail("distortion must be finite");
  if (c.projection == CameraProjection::kFisheye)
    for (double d : c.distortion)
      if (d != 0.0)
        fail("distortion must be zero for the equidistant fisheye");
  if (!std::isfinite(c.stereo_tx))
    fail("stereo_tx must be finite");
  if (!(c.max_range > 0.0 && std::isfinite(c.max_range)))
    fail("max_range must be finite and > 0 m");
  if (!(c.shadow_range > 0.0 && std::isfinite(c.shadow_range)))
    fail("shadow_range must be finite and > 0 m");
  if (!(c.min_exposure_lux > 0.0 && std::isfinite(c.min_exposure_lux)))
    fail("min_exposure_lux must be finite and > 0 lx");
  if (!(c.sky_gain >= 0.0 && std::isfinite(c.sky_gain)))
    fail("sky_gain must be finite and >= 0");
  if (!(c.fog_contrast_threshold > 0.0 && c.fog_contrast_threshold < 1.0))
    fail("fog_contrast_threshold must be in (0, 1)");
  if (!(c.thermal_min > 0.0 && c.thermal_max > c.thermal_min && std::isfinite(c.thermal_max)))
    fail("thermal_min, thermal_max must satisfy 0 < thermal_min < thermal_max (K)");
  if (!(c.rgb || c.depth || c.semantic || c.thermal))
    fail("at least one output (rgb, depth, semantic, thermal) is required");
  if (!c.mount.matrix().allFinite())
    fail("mount must be finite");
}

Eigen::Matrix3d opticalFromBody()
{
  // Columns: the optical axes in the body frame (x right = -y, y down = -z, z forward = x).
  Eigen::Matrix3d r;
  r << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return r;
}

CameraIntrinsics cameraIntrinsics(const CameraConfig& c)
{
  CameraIntrinsics in;
  in.width = c.width;
  in.height = c.height;
  const double half = 0.5 * c.width;
  if (c.projection == CameraProjection::kPinhole)
  {
    in.fx = half / std::tan(0.5 * c.hfov);
    in.distortion_model = "plumb_bob";
    in.D.assign(c.distortion.begin(), c.distortion.end());
  }
  else
  {
    in.fx = half / (0.5 * c.hfov);
    in.distortion_model = "equidistant";
    in.D.assign(4, 0.0);
  }
  in.fy = in.fx;
  in.cx = 0.5 * (c.width - 1);
  in.cy = 0.5 * (c.height - 1);
  in.K = { in.fx, 0, in.cx, 0, in.fy, in.cy, 0, 0, 1 };
  in.R = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
  in.P = { in.fx, 0, in.cx, in.fx * c.stereo_tx, 0, in.fy, in.cy, 0, 0, 0, 1, 0 };
  return in;
}

// ---- camera ------------------------------------------------------------------------------
Camera::Camera(CameraConfig config) : config_(std::move(config))
{
  validateCameraConfig(config_);
  intrinsics_ = cameraIntrinsics(config_);
  const CameraIntrinsics& in = intrinsics_;
  const auto& d = config_.distortion;
  rays_.resize(static_cast<std::size_t>(config_.width) * config_.height);
  for (int v = 0; v < config_.height; ++v)
    for (int u = 0; u < config_.width; ++u)
    {
      const double xd = (u - in.cx) / in.fx, yd = (v - in.cy) / in.fy;
      Eigen::Vector3d ray;
      if (config_.projection == CameraProjection::kPinhole)
      {
        // Undistort by fixed-point iteration (plumb_bob has no closed-form inverse).
        double x = xd, y = yd;
        const bool distorted = d[0] != 0.0 || d[1] != 0.0 || d[2] != 0.0 || d[3] != 0.0 || d[4] != 0.0;
        for (int it = 0; distorted && it < 30; ++it)
        {
          const double r2 = x * x + y * y;
          const double radial = 1.0 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
          const double dx = 2.0 * d[2] * x * y + d[3] * (r2 + 2.0 * x * x);
          const double dy = d[2] * (r2 + 2.0 * y * y) + 2.0 * d[3] * x * y;
          x = (xd - dx) / radial;
          y = (yd - dy) / radial;
        }
        ray = Eigen::Vector3d(x, y, 1.0).normalized();
      }
      else
      {
        const double r = std::hypot(xd, yd);  // = theta (equidistant, f in pixels)
        if (r > 0.5 * config_.hfov || r > kPi)
          ray.setZero();  // outside the lens's image circle
        else if (r == 0.0)
          ray = Eigen::Vector3d::UnitZ();
        else
          ray = Eigen::Vector3d(std::sin(r) * xd / r, std::sin(r) * yd / r, std::cos(r));
      }
      rays_[static_cast<std::size_t>(v) * config_.width + u] = ray.cast<float>();
    }
}

bool Camera::project(const Eigen::Vector3d& p, Eigen::Vector2d& uv) const
{
  const CameraIntrinsics& in = intrinsics_;
  if (config_.projection == CameraProjection::kPinhole)
  {
    if (!(p.z() > 0.0))
      return false;
    const double x = p.x() / p.z(), y = p.y() / p.z();
    const auto& d = config_.distortion;
    const double r2 = x * x + y * y;
    const double radial = 1.0 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
    const double xd = x * radial + 2.0 * d[2] * x * y + d[3] * (r2 + 2.0 * x * x);
    const double yd = y * radial + d[2] * (r2 + 2.0 * y * y) + 2.0 * d[3] * x * y;
    uv = Eigen::Vector2d(in.fx * xd + in.cx, in.fy * yd + in.cy);
    return true;
  }
  const double rho = std::hypot(p.x(), p.y());
  const double theta = std::atan2(rho, p.z());
  if (theta > 0.5 * config_.hfov)
    return false;
  const double scale = rho > 0.0 ? theta / rho : 0.0;
  uv = Eigen::Vector2d(in.fx * p.x() * scale + in.cx, in.fy * p.y() * scale + in.cy);
  return true;
}

namespace
{
/// Linear value at which the 8-bit sRGB code steps from k - 1 to k (k = 1 .. 255): the inverse
/// transfer function at (k - 0.5) / 255. A binary search over it replaces a pow() per channel.
struct SrgbThresholds
{
  /// Buckets of [0, 1) for the first guess (a power of two: linear * kBuckets is exact).
  static constexpr int kBuckets = 4096;
  std::array<float, 255> t;
  /// start[b]: the code of b / kBuckets, where codes in bucket b begin; the thresholds inside
  /// one bucket are counted from there (at most a few: the densest are ~3e-4 apart near 0).
  std::array<std::uint8_t, kBuckets> start;
  SrgbThresholds()
  {
    for (int k = 1; k <= 255; ++k)
    {
      const double s = (k - 0.5) / 255.0;
      t[k - 1] = static_cast<float>(s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4));
    }
    for (int b = 0; b < kBuckets; ++b)
      start[b] =
          static_cast<std::uint8_t>(std::upper_bound(t.begin(), t.end(), static_cast<float>(b) / kBuckets) - t.begin());
  }
};
const SrgbThresholds kSrgb;
}  // namespace

void drawPrecipitation(CameraFrame& f, const CameraEnvironment& env, float light, std::uint64_t key)
{
  const double rain = env.weather.rain_rate, snow = env.weather.snow_rate;
  if (!(rain > 0.0) && !(snow > 0.0))
    return;
  StreamRng rng(streamKey(key, 0x5eed, 0));
  const int w = f.width, h = f.height;
  const double pixels = static_cast<double>(w) * h;
  auto blend = [&](int u, int v, float level, float weight) {
    if (u < 0 || v < 0 || u >= w || v >= h)
      return;
    float* p = &f.radiance[3 * (static_cast<std::size_t>(v) * w + u)];
    for (int ch = 0; ch < 3; ++ch)
      p[ch] = p[ch] * (1.f - weight) + level * weight;
  };
  // Rain: drops blurred into near-vertical streaks over the exposure, 0.2 % of the pixels'
  // worth of streaks at 25 mm/h and more (fewer in lighter rain), 2-6 % of the image tall.
  const int streaks = static_cast<int>(0.002 * pixels * std::min(1.0, rain / 25.0));
  for (int n = 0; n < streaks; ++n)
  {
    const double u0 = rng.uniform() * w, v0 = rng.uniform() * h;
    const int length = std::max(2, static_cast<int>((0.02 + 0.04 * rng.uniform()) * h));
    const double slant = 0.1 * (rng.uniform() - 0.5);
    for (int i = 0; i < length; ++i)
      blend(static_cast<int>(u0 + slant * i), static_cast<int>(v0) + i, 0.9f * light, 0.3f);
  }
  // Snow: flakes as small bright discs, 0.2 % of the pixels' worth at 5 mm/h and more.
  const int flakes = static_cast<int>(0.002 * pixels * std::min(1.0, snow / 5.0));
  for (int n = 0; n < flakes; ++n)
  {
    const double u0 = rng.uniform() * w, v0 = rng.uniform() * h;
    const double r = 0.5 + 1.5 * rng.uniform();
    const int ri = static_cast<int>(std::ceil(r));
    for (int dv = -ri; dv <= ri; ++dv)
      for (int du = -ri; du <= ri; ++du)
        if (du * du + dv * dv <= r * r)
          blend(static_cast<int>(u0) + du, static_cast<int>(v0) + dv, 0.85f * light, 0.8f);
  }
}

std::uint8_t encodeSrgb(float linear)
{
  // Code k when t[k - 1] <= linear < t[k]: the number of thresholds at or below the value,
  // counted from the code at the start of the value's bucket (the same answer as a binary
  // search over all 255, a third of the cost).
  if (!(linear >= 0.f))
    return std::isnan(linear) ? 255 : 0;  // NaN: what the binary search gave (no threshold above it)
  if (!(linear < 1.f))
    return 255;
  int code = kSrgb.start[static_cast<int>(linear * SrgbThresholds::kBuckets)];
  while (code < 255 && kSrgb.t[code] <= linear)
    ++code;
  return static_cast<std::uint8_t>(code);
}

namespace
{
/// A frame's light: everything a pixel needs that does not depend on the pixel.
struct FrameLight
{
  SkyLight sky;
  double exposure = 0.0;  ///< lux the frame is exposed for
  float inv_exposure = 0.f;
  bool sun_up = false, moon_up = false;
  Eigen::Vector3d sun, moon;  ///< unit directions toward them
  Eigen::Vector3f ambient_tint;
  double alpha = 0.0;          ///< 1/m, extinction of fog and precipitation
  double t_air = 0.0;          ///< K
  double sky_cooling = 0.0;    ///< K, clear sky below air temperature
  double night_cooling = 0.0;  ///< K, surfaces radiating to a clear sky
  float sky_scale = 0.f;

  FrameLight(const CameraConfig& c, const CameraEnvironment& env)
    : sky(skyLight(env)), sun(env.sun_direction), moon(env.moon_direction), t_air(env.air_temperature)
  {
    exposure = std::max(sky.horizontal_total, c.min_exposure_lux);
    inv_exposure = static_cast<float>(1.0 / exposure);
    sun_up = sky.sun_normal > 0.0;
    moon_up = sky.moon_normal > 0.0;
    ambient_tint = normalised(0.5f * (sky.sky_zenith + sky.sky_horizon));
    const double v = env.weather.fog_visibility;
    // Fog: alpha = -ln(eps) / V (eps = 0.02: Koschmieder's 3.912 / V, the lidar's); rain and
    // snow add their extinction at 550 nm.
    alpha = (std::isfinite(v) ? -std::log(c.fog_contrast_threshold) / v : 0.0) +
            precipitationExtinction(env.weather, 550e-9);
    const float haze = static_cast<float>(std::isfinite(v) ? clamp01(1.0 - v / 10000.0) : 0.0);
    sky_cooling = 20.0 * (1.0 - haze);
    night_cooling = 3.0 * (1.0 - haze);
    sky_scale = static_cast<float>(c.sky_gain * sky.sky_horizontal) * inv_exposure;
  }

  Eigen::Vector3f skyRadiance(const Eigen::Vector3d& d) const
  {
    const float up = static_cast<float>(std::sqrt(std::max(0.0, d.z())));
    // Clear skies are brighter toward the horizon: luminance 1.3 there, 0.7 at the zenith.
    const Eigen::Vector3f colour = sky.sky_horizon * (1.3f * (1.f - up)) + sky.sky_zenith * (0.7f * up);
    return colour * sky_scale;
  }
};

/// Pixel k of a ray that hit nothing: the sky's radiance and temperature, an infinite depth.
void shadeSky(const CameraConfig& c, const FrameLight& light, const Eigen::Vector3d& direction, std::size_t k,
              CameraFrame& f)
{
  if (c.depth)
    f.depth[k] = std::numeric_limits<float>::infinity();
  if (c.rgb)
  {
    const Eigen::Vector3f s = light.skyRadiance(direction);
    for (int ch = 0; ch < 3; ++ch)
      f.radiance[3 * k + ch] = s[ch];
  }
  if (c.thermal)
    f.temperature[k] = static_cast<float>(light.t_air - light.sky_cooling * std::sqrt(std::max(0.0, direction.z())));
}

/// Pixel k's radiance and temperature where its ray hit a surface of class cls.
void shadeHit(const CameraConfig& c, const Scene& scene, const CameraMaterials& materials, const CameraEnvironment& env,
              const FrameLight& light, const Ray& ray, const RayHit& hit, std::uint8_t cls, std::size_t k,
              CameraFrame& f)
{
  const SkyLight& sky = light.sky;
  // Albedo: soil (wetness darkens, Lobell and Asner: up to about half when saturated) or class.
  Eigen::Vector3f albedo;
  if (hit.kind == HitKind::kTerrain)
  {
    const SoilLook& soil = materials.soils()[materials.soilAt(scene.terrain(), hit.point.x(), hit.point.y())];
    const float wet = std::min(1.f, soil.wetness + static_cast<float>(env.surface_wetness));
    albedo = soil.albedo * (1.f - 0.5f * wet);
  }
  else
    albedo = classAlbedo(cls, env.season);
  Eigen::Vector3d normal = hit.normal;
  if (normal.dot(ray.direction) > 0.0)
    normal = -normal;
  if (hit.kind != HitKind::kBody && env.snow_cover > 0.0)
  {
    const float w = static_cast<float>(env.snow_cover * clamp01((normal.z() - 0.5) / 0.3));
    albedo = albedo * (1.f - w) + kSnowAlbedo * w;
  }
  // Direct sun with a hard shadow ray (the own vehicle casts shadows too).
  double sun_on = 0.0;
  const double cos_sun = normal.dot(light.sun);
  if (light.sun_up && cos_sun > 0.0)
  {
    bool lit = true;
    if (c.shadows)
    {
      Ray shadow;
      shadow.origin = hit.point + 5e-3 * normal;
      shadow.direction = light.sun;
      shadow.max_range = c.shadow_range;
      lit = !scene.occluded(shadow);
    }
    if (lit)
      sun_on = sky.sun_normal * cos_sun;
  }
  if (c.rgb)
  {
    const double moon_on = light.moon_up ? sky.moon_normal * std::max(0.0, normal.dot(light.moon)) : 0.0;
    // Sky seen by a tilted surface (isotropic sky view factor (1 + n_z) / 2) plus light
    // reflected by the ground (albedo 0.2) on faces turned down.
    const double sky_on = sky.sky_horizontal * 0.5 * (1.0 + normal.z());
    const double ground_on = 0.2 * sky.horizontal_total * 0.5 * (1.0 - normal.z());
    const Eigen::Vector3f e = Eigen::Vector3f::Constant(static_cast<float>(sun_on + moon_on + ground_on)) +
                              light.ambient_tint * static_cast<float>(sky_on);
    Eigen::Vector3f l = albedo.cwiseProduct(e) * light.inv_exposure;
    if (light.alpha > 0.0)
    {
      // Koschmieder: the object's light decays by T, the airlight of the sky behind fills in.
      const float t = static_cast<float>(std::exp(-light.alpha * hit.range));
      l = l * t + light.skyRadiance(ray.direction) * (1.f - t);
    }
    for (int ch = 0; ch < 3; ++ch)
      f.radiance[3 * k + ch] = l[ch];
  }
  if (c.thermal)
  {
    double temp;
    if (hit.kind == HitKind::kBody)
    {
      temp = materials.bodyTemperature(hit.id);
      if (std::isnan(temp))
        temp = cls == kClassPerson ? 305.0 : (cls == kClassAnimal ? 303.0 : light.t_air + 25.0);
    }
    else
    {
      // Solar gain (sunlight ~110 lm/W) absorbed (1 - albedo) over convection.
      const double absorbed = (1.0 - luminance(albedo)) * sun_on / 110.0;
      temp = light.t_air + absorbed / convectiveCoefficient(cls) - light.night_cooling;
    }
    if (light.alpha > 0.0)
    {
      const double t = std::exp(-light.alpha * hit.range);
      temp = temp * t + light.t_air * (1.0 - t);
    }
    f.temperature[k] = static_cast<float>(temp);
  }
}

/// The frame's outputs sized for the configured images (RGB, depth, semantic, thermal).
CameraFrame blankFrame(const CameraConfig& c)
{
  const std::size_t n = static_cast<std::size_t>(c.width) * c.height;
  CameraFrame f;
  f.width = c.width;
  f.height = c.height;
  if (c.rgb)
  {
    f.rgb.assign(3 * n, 0);
    f.radiance.assign(3 * n, 0.f);
  }
  if (c.depth)
    f.depth.assign(n, std::numeric_limits<float>::quiet_NaN());
  if (c.semantic)
    f.semantic.assign(n, kClassNone);
  if (c.thermal)
  {
    f.temperature.assign(n, std::numeric_limits<float>::quiet_NaN());
    f.thermal.assign(n, 0);
  }
  return f;
}

/// The radiance and temperatures coded as 8-bit sRGB and thermal images.
void encodeFrame(const CameraConfig& c, unsigned threads, CameraFrame& f)
{
  parallelFor(static_cast<std::size_t>(c.height), threads, [&](std::size_t row_begin, std::size_t row_end) {
    for (std::size_t row = row_begin; row < row_end; ++row)
      for (std::size_t col = 0; col < static_cast<std::size_t>(c.width); ++col)
      {
        const std::size_t k = row * c.width + col;
        if (c.rgb)
          for (int ch = 0; ch < 3; ++ch)
            f.rgb[3 * k + ch] = encodeSrgb(f.radiance[3 * k + ch]);
        if (c.thermal && !std::isnan(f.temperature[k]))
        {
          const double x = (f.temperature[k] - c.thermal_min) / (c.thermal_max - c.thermal_min);
          f.thermal[k] = static_cast<std::uint8_t>(std::lround(255.0 * clamp01(x)));
        }
      }
  });
}
}  // namespace

CameraFrame Camera::render(const Scene& scene, const CameraMaterials& materials, const Eigen::Isometry3d& pose,
                           const CameraEnvironment& env, unsigned threads, std::uint32_t ignore_body,
                           std::uint64_t noise_key) const
{
  if (!pose.matrix().allFinite())
    throw std::invalid_argument("Camera::render '" + config_.name + "': pose is not finite");
  validateCameraEnvironment(env);
  const CameraConfig& c = config_;
  CameraFrame f = blankFrame(c);
  const FrameLight light(c, env);
  f.exposure_lux = light.exposure;
  const Eigen::Matrix3d rot = pose.linear();
  const Eigen::Vector3d origin = pose.translation();
  // Rows are handed out a few at a time to whichever thread is free: their costs differ by an
  // order of magnitude (sky, grazing rays near the horizon, ground with shadow rays), so a
  // fixed half-and-half split left one thread idle. Each pixel depends on its ray alone.
  parallelForDynamic(static_cast<std::size_t>(c.height), threads, 4, [&](std::size_t row_begin, std::size_t row_end) {
    for (std::size_t row = row_begin; row < row_end; ++row)
      for (std::size_t col = 0; col < static_cast<std::size_t>(c.width); ++col)
      {
        const std::size_t k = row * c.width + col;
        const Eigen::Vector3f& ro = rays_[k];
        if (ro.z() == 0.f && ro.x() == 0.f && ro.y() == 0.f)
          continue;  // outside a fisheye's image circle: no data
        Ray ray;
        ray.origin = origin;
        ray.direction = (rot * ro.cast<double>()).normalized();
        ray.max_range = c.max_range;
        ray.ignore_body = ignore_body;
        const RayHit hit = scene.cast(ray);
        const std::uint8_t cls = materials.classOf(hit, scene.terrain());
        if (c.semantic)
          f.semantic[k] = cls;
        if (!hit.hit())
        {
          shadeSky(c, light, ray.direction, k, f);
          continue;
        }
        if (c.depth)
          f.depth[k] = static_cast<float>(hit.range * ro.z());
        if (c.rgb || c.thermal)
          shadeHit(c, scene, materials, env, light, ray, hit, cls, k, f);
      }
  });
  if (c.rgb && c.precipitation)
    drawPrecipitation(f, env, static_cast<float>(std::min(1.0, light.sky.horizontal_total / light.exposure)),
                      noise_key);
  encodeFrame(c, threads, f);
  return f;
}

}  // namespace sensors
}  // namespace avsp
