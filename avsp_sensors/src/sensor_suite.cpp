#include "avsp_sensors/sensor_suite.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>
#include <stdexcept>
#include <string>

#include "avsp_sensors/random.hpp"
#include "avsp_sensors/terrain_patch.hpp"

namespace avsp
{
namespace sensors
{
namespace
{
/// Relative tolerance (of a period) within which a time counts as on a grid time.
constexpr double kGridTolerance = 1e-9;

bool rotationOk(const Eigen::Matrix3d& R)
{
  return (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <= 1e-6 && R.determinant() > 0.0;
}

void checkMount(const Eigen::Isometry3d& mount, const std::string& context)
{
  if (!mount.matrix().allFinite())
    throw std::invalid_argument(context + ": mount is not finite");
  if (!rotationOk(mount.linear()))
    throw std::invalid_argument(context + ": mount rotation is not a rotation matrix");
}

/// Seeds of the sensors of one suite: independent streams of the suite's seed.
std::uint64_t sensorSeed(std::uint64_t seed, std::uint64_t kind, std::uint64_t index = 0)
{
  return streamKey(seed, 0x5e5503ull + kind, index);
}

/// Wall seconds since `start`.
double since(std::chrono::steady_clock::time_point start)
{
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// Skew-free rotation vector of R (angle-axis), rad.
Eigen::Vector3d rotationVector(const Eigen::Matrix3d& R)
{
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}
}  // namespace

void validateState(const VehicleState& s, const char* context)
{
  const std::string ctx(context);
  if (!std::isfinite(s.time))
    throw std::invalid_argument(ctx + ": time is not finite");
  if (!s.pose.matrix().allFinite())
    throw std::invalid_argument(ctx + ": pose is not finite");
  if (!rotationOk(s.pose.linear()))
    throw std::invalid_argument(ctx + ": pose rotation is not a rotation matrix");
  if (!s.linear_velocity.allFinite())
    throw std::invalid_argument(ctx + ": linear_velocity is not finite");
  if (!s.angular_velocity.allFinite())
    throw std::invalid_argument(ctx + ": angular_velocity is not finite");
}

// ---------------------------------------------------------------------------------------------
GridClock::GridClock(double rate) : period_(1.0 / rate)
{
}

bool GridClock::due(double t)
{
  if (!started_)
  {
    // The first grid time at or after the first time seen.
    next_ = std::ceil(t / period_ - kGridTolerance) * period_;
    started_ = true;
  }
  return t >= next_ - kGridTolerance * period_;
}

void GridClock::taken(double t)
{
  started_ = true;
  next_ = (std::floor(t / period_ + kGridTolerance) + 1.0) * period_;
}

std::uint64_t GridClock::index(double t) const
{
  return static_cast<std::uint64_t>(std::max(0.0, std::round(t / period_)));
}

// ---------------------------------------------------------------------------------------------
std::vector<Body> vehicleBodies(const std::vector<BodyBox>& boxes, const VehicleState& state, std::uint32_t id,
                                float reflectivity)
{
  std::vector<Body> bodies;
  bodies.reserve(boxes.size());
  const Eigen::Vector3d p = state.pose.translation();
  for (const BodyBox& box : boxes)
  {
    Body b;
    b.primitive.shape = Shape::kBox;
    b.primitive.half_extents = 0.5 * box.size;
    b.primitive.centre = state.pose * box.pose.translation();
    b.primitive.rotation = state.pose.linear() * box.pose.linear();
    b.primitive.id = id;
    b.primitive.reflectivity = reflectivity;
    b.velocity = state.linear_velocity + state.angular_velocity.cross(b.primitive.centre - p);
    b.angular_velocity = state.angular_velocity;
    bodies.push_back(b);
  }
  return bodies;
}

// ---------------------------------------------------------------------------------------------
void validateSuiteConfig(const SuiteConfig& c)
{
  if (c.lidar)
  {
    validateLidarConfig(c.lidar->config);
    checkMount(c.lidar->mount, "lidar");
    if (c.lidar->clustering)
      validateLidarClusterConfig(*c.lidar->clustering);
  }
  if (c.radar)
  {
    validateRadarConfig(c.radar->config);
    check::positive("RadarSetup", "rate", c.radar->rate);
    checkMount(c.radar->mount, "radar");
  }
  if (c.gps)
  {
    validateGpsConfig(c.gps->config);
    checkMount(c.gps->mount, "gps");
  }
  if (c.imu)
    validateImuConfig(*c.imu);
  if (c.magnetometer)
    validateMagnetometerConfig(*c.magnetometer);
  std::set<std::string> names;
  for (const UltrasonicSetup& u : c.ultrasonics)
  {
    if (u.name.empty())
      throw std::invalid_argument("ultrasonic: name must not be empty");
    if (!names.insert(u.name).second)
      throw std::invalid_argument("ultrasonic '" + u.name + "': name is used twice");
    validateUltrasonicConfig(u.config);
    checkMount(u.mount, "ultrasonic '" + u.name + "'");
  }
  if (c.occupancy)
  {
    if (!c.lidar)
      throw std::invalid_argument("occupancy: needs a lidar (the map is built from its sweeps)");
    validateOccupancyConfig(c.occupancy->config);
    if (c.occupancy->slices == 0)
      throw std::invalid_argument("occupancy: slices must be >= 1");
    check::positive("occupancy", "publish_rate", c.occupancy->publish_rate);
    check::positive("occupancy", "grid_size", c.occupancy->grid_size);
    const GridProjection& g = c.occupancy->projection;
    check::nonNegative("occupancy", "grid_resolution", g.resolution);
    check::finite("occupancy", "min_height", g.min_height);
    check::finite("occupancy", "obstacle_height", g.obstacle_height);
    check::finite("occupancy", "max_height", g.max_height);
    check::finite("occupancy", "free_max_height", g.free_max_height);
    if (!(g.obstacle_height > g.min_height))
      throw std::invalid_argument("occupancy: obstacle_height must be > min_height");
    if (!(g.max_height > g.obstacle_height))
      throw std::invalid_argument("occupancy: max_height must be > obstacle_height");
    if (!(g.free_max_height >= g.min_height))
      throw std::invalid_argument("occupancy: free_max_height must be >= min_height");
    const double res = g.resolution > 0.0 ? g.resolution : c.occupancy->config.resolution;
    if (c.occupancy->grid_size / res > 20000.0)
      throw std::invalid_argument("occupancy: grid_size / resolution must be <= 20000 cells per side");
  }
}

// ---------------------------------------------------------------------------------------------
VehicleSensors::VehicleSensors(SuiteConfig config, std::optional<EnuFrame> origin, std::uint32_t body_id)
  : config_(std::move(config)), body_id_(body_id)
{
  validateSuiteConfig(config_);
  const std::uint64_t seed = config_.seed;
  if (config_.lidar)
  {
    lidar_ = std::make_unique<Lidar>(config_.lidar->config, sensorSeed(seed, 1));
    sweep_clock_.emplace(config_.lidar->config.rotation_rate);
    if (config_.lidar->clustering)
      clusterer_ = std::make_unique<LidarClusterer>(*config_.lidar->clustering);
  }
  if (config_.radar)
  {
    radar_ = std::make_unique<Radar>(config_.radar->config, sensorSeed(seed, 2));
    radar_clock_.emplace(config_.radar->rate);
  }
  if (config_.gps)
  {
    if (!origin)
      throw std::invalid_argument("gps: needs the scenario's geodetic reference (origin)");
    gps_ = std::make_unique<Gps>(config_.gps->config, *origin, sensorSeed(seed, 3));
    gps_clock_.emplace(config_.gps->config.rate);
  }
  if (config_.imu)
  {
    imu_ = std::make_unique<Imu>(*config_.imu, sensorSeed(seed, 4));
    imu_clock_.emplace(config_.imu->rate);
  }
  if (config_.magnetometer)
  {
    magnetometer_ = std::make_unique<Magnetometer>(*config_.magnetometer, sensorSeed(seed, 5));
    mag_clock_.emplace(config_.magnetometer->rate);
  }
  for (std::size_t k = 0; k < config_.ultrasonics.size(); ++k)
  {
    ultrasonics_.emplace_back(config_.ultrasonics[k].config, sensorSeed(seed, 6, k));
    ultrasonic_clocks_.emplace_back(config_.ultrasonics[k].config.rate);
  }
  if (config_.occupancy)
  {
    occupancy_ = std::make_unique<OccupancyMap>(config_.occupancy->config);
    occupancy_clock_.emplace(config_.occupancy->publish_rate);
  }
}

VehicleSensors::~VehicleSensors() = default;
VehicleSensors::VehicleSensors(VehicleSensors&&) noexcept = default;
VehicleSensors& VehicleSensors::operator=(VehicleSensors&&) noexcept = default;

SuiteOutput VehicleSensors::update(const VehicleState& state, const Scene& scene, const Weather& weather,
                                   unsigned threads)
{
  validateState(state, "VehicleSensors::update");
  if (last_ && state.time < last_->time)
    throw std::invalid_argument("VehicleSensors::update: time " + std::to_string(state.time) +
                                " s is earlier than the last state's (" + std::to_string(last_->time) + " s)");
  const double t = state.time;
  const Eigen::Isometry3d& P = state.pose;
  const Eigen::Vector3d& v = state.linear_velocity;
  const Eigen::Vector3d& w = state.angular_velocity;
  // Velocity of a point of the body mounted at `m` (base_link), map.
  auto pointVelocity = [&](const Eigen::Isometry3d& m) -> Eigen::Vector3d {
    return v + w.cross(P.linear() * m.translation());
  };

  SuiteOutput out;
  out.time = t;

  // IMU accelerations: backward differences of the states' velocities (zero at the first).
  Eigen::Vector3d a = Eigen::Vector3d::Zero(), alpha = Eigen::Vector3d::Zero();
  if (last_ && t > last_->time)
  {
    a = (v - last_->linear_velocity) / (t - last_->time);
    alpha = (w - last_->angular_velocity) / (t - last_->time);
  }

  if (lidar_)
    sweepLidar(state, scene, weather, threads, out);

  if (radar_ && radar_clock_->due(t))
  {
    RadarScanRequest req;
    req.pose = P * config_.radar->mount;
    req.velocity = pointVelocity(config_.radar->mount);
    req.scan = radar_clock_->index(t);
    req.threads = threads;
    req.ignore_body = body_id_;
    RadarOutput r;
    r.pose = req.pose;
    const auto start = std::chrono::steady_clock::now();
    r.scan = radar_->scan(scene, req);
    out.cost.radar = since(start);
    out.radar = std::move(r);
    radar_clock_->taken(t);
  }

  const auto others_start = std::chrono::steady_clock::now();
  if (gps_ && gps_clock_->due(t))
  {
    out.gps = gps_->measure(t, P * config_.gps->mount.translation());
    gps_clock_->taken(t);
  }

  if (imu_ && imu_clock_->due(t))
  {
    ImuInput in;
    in.time = t;
    in.pose = P;
    in.linear_velocity = v;
    in.angular_velocity = w;
    in.linear_acceleration = a;
    in.angular_acceleration = alpha;
    out.imu = imu_->measure(in);
    imu_clock_->taken(t);
  }

  if (magnetometer_ && mag_clock_->due(t))
  {
    out.magnetometer = magnetometer_->measure(t, P);
    mag_clock_->taken(t);
  }

  for (std::size_t k = 0; k < ultrasonics_.size(); ++k)
    if (ultrasonic_clocks_[k].due(t))
    {
      out.ultrasonics.emplace_back(k, ultrasonics_[k].measure(scene, t, P * config_.ultrasonics[k].mount, body_id_));
      ultrasonic_clocks_[k].taken(t);
    }

  out.cost.other = since(others_start);

  if (occupancy_ && occupancy_clock_->due(t))
  {
    out.occupancy_due = true;
    occupancy_clock_->taken(t);
  }

  last_ = state;
  return out;
}

void VehicleSensors::sweepLidar(const VehicleState& state, const Scene& scene, const Weather& weather, unsigned threads,
                                SuiteOutput& out)
{
  const double t = state.time;
  const Eigen::Isometry3d& P = state.pose;
  if (sweep_start_ && sweep_clock_->due(t))
  {
    // The sweep ran from sweep_start_ to this state: the constant twist that takes the sensor
    // from its pose then to its pose now.
    const VehicleState& s0 = *sweep_start_;
    const Eigen::Isometry3d& mount = config_.lidar->mount;
    const Eigen::Isometry3d q0 = s0.pose * mount, q1 = P * mount;
    const double dt = t - s0.time;
    LidarSweep sweep;
    sweep.start = s0.time;
    sweep.motion.pose = q0;
    if (dt > 0.0)
    {
      sweep.motion.linear_velocity = (q1.translation() - q0.translation()) / dt;
      sweep.motion.angular_velocity = rotationVector(q1.linear() * q0.linear().transpose()) / dt;
    }
    LidarScanRequest req;
    req.motion = sweep.motion;
    req.weather = weather;
    req.sweep = sweep_clock_->index(s0.time);
    req.registered = config_.lidar->registered;
    req.threads = threads;
    req.ignore_body = body_id_;
    auto start = std::chrono::steady_clock::now();
    sweep.scan = lidar_->scan(scene, req);
    out.cost.lidar = since(start);
    if (occupancy_)
    {
      start = std::chrono::steady_clock::now();
      occupancy_->insert(sweep.scan, sweep.motion, config_.occupancy->slices);
      out.cost.occupancy = since(start);
    }
    out.lidar = std::move(sweep);
    sweep_clock_->taken(t);
    sweep_start_ = state;
  }
  else if (!sweep_start_ && sweep_clock_->due(t))
  {
    sweep_clock_->taken(t);
    sweep_start_ = state;  // the first sweep starts here
  }
}

OccupancyGrid2D VehicleSensors::occupancyGrid(double x, double y, const HeightField& terrain) const
{
  if (!occupancy_)
    throw std::logic_error("VehicleSensors::occupancyGrid: no occupancy map configured");
  const OccupancySetup& o = *config_.occupancy;
  GridProjection g = o.projection;
  const double res = g.resolution > 0.0 ? g.resolution : o.config.resolution;
  const std::size_t cells = std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(o.grid_size / res)));
  g.resolution = res;
  g.width = g.height = cells;
  g.origin_x = std::floor((x - 0.5 * cells * res) / res) * res;
  g.origin_y = std::floor((y - 0.5 * cells * res) / res) * res;
  return occupancy_->projectGrid(g,
                                 [&terrain](double px, double py, double& pz) { return terrain.heightAt(px, py, pz); });
}

LidarClustering VehicleSensors::clusterSweep(const LidarSweep& sweep, const HeightField& terrain) const
{
  if (!clusterer_)
    throw std::logic_error("VehicleSensors::clusterSweep: no lidar clustering configured");
  return clusterer_->cluster(sweep.scan, sweep.motion,
                             [&terrain](double x, double y, double& z) { return terrain.heightAt(x, y, z); });
}

// ---------------------------------------------------------------------------------------------
StateSynchronizer::StateSynchronizer(std::size_t vehicles, double timeout)
  : timeout_(timeout),
    queues_(vehicles),
    latest_(vehicles),
    last_pushed_(vehicles, -std::numeric_limits<double>::infinity()),
    first_(vehicles, -std::numeric_limits<double>::infinity()),
    last_(vehicles, std::numeric_limits<double>::infinity())
{
  if (!(timeout >= 0.0))
    throw std::invalid_argument("StateSynchronizer: timeout must be >= 0");
}

std::size_t StateSynchronizer::addVehicle(double first_time)
{
  if (!(first_time > released_))
    throw std::invalid_argument("StateSynchronizer::addVehicle: first time " + std::to_string(first_time) +
                                " s is not after the last released time " + std::to_string(released_) + " s");
  queues_.emplace_back();
  latest_.emplace_back();
  last_pushed_.push_back(-std::numeric_limits<double>::infinity());
  first_.push_back(first_time);
  last_.push_back(std::numeric_limits<double>::infinity());
  return queues_.size() - 1;
}

void StateSynchronizer::removeVehicle(std::size_t vehicle, double last_time)
{
  if (vehicle >= queues_.size())
    throw std::out_of_range("StateSynchronizer::removeVehicle: no vehicle " + std::to_string(vehicle));
  last_[vehicle] = std::min(last_[vehicle], last_time);
  std::deque<VehicleState>& q = queues_[vehicle];
  while (!q.empty() && q.back().time > last_[vehicle])
    q.pop_back();
}

StateSynchronizer::Push StateSynchronizer::push(std::size_t vehicle, const VehicleState& state)
{
  if (!(state.time > last_pushed_.at(vehicle)) || state.time > last_[vehicle])
    return Push::kNotAfterLast;
  if (state.time < released_)
    return Push::kLate;
  last_pushed_[vehicle] = state.time;
  newest_ = std::max(newest_, state.time);
  queues_[vehicle].push_back(state);
  return Push::kQueued;
}

std::optional<StateSynchronizer::Batch> StateSynchronizer::next()
{
  waited_out_.clear();
  double t = std::numeric_limits<double>::infinity();
  for (const auto& q : queues_)
    if (!q.empty())
      t = std::min(t, q.front().time);
  if (!std::isfinite(t))
    return std::nullopt;
  for (std::size_t k = 0; k < queues_.size(); ++k)
    if (queues_[k].empty() && t >= first_[k] && t <= last_[k])
    {
      if (!(newest_ > t + timeout_))
        return std::nullopt;  // it may still deliver a state at or before t
      waited_out_.push_back(k);
    }
  Batch b;
  b.time = t;
  for (std::size_t k = 0; k < queues_.size(); ++k)
    if (!queues_[k].empty() && queues_[k].front().time == t)
    {
      b.vehicles.push_back(k);
      b.states.push_back(queues_[k].front());
      latest_[k] = queues_[k].front();
      queues_[k].pop_front();
    }
  released_ = t;
  for (std::size_t k = 0; k < queues_.size(); ++k)
    if (t > last_[k])
      latest_[k].reset();  // removed: no longer in the scene
  return b;
}

// ---------------------------------------------------------------------------------------------
std::optional<terrain::PointRange> applyHeightPatch(HeightField& field, const terrain::HeightPatch& patch)
{
  const auto bad = [](const std::string& what) { throw std::invalid_argument("TerrainPatch: " + what); };
  if (!std::isfinite(patch.resolution) || patch.resolution <= 0.0)
    bad("resolution " + std::to_string(patch.resolution) + " m is not a positive number");
  if (std::abs(field.dx() - field.dy()) > 1e-9 * field.dx())
    bad("the terrain grid is not square (dx " + std::to_string(field.dx()) + " m, dy " + std::to_string(field.dy()) +
        " m); patches need square cells");
  if (std::abs(patch.resolution - field.dx()) > 1e-9 * field.dx())
    bad("resolution " + std::to_string(patch.resolution) + " m differs from the terrain grid spacing " +
        std::to_string(field.dx()) + " m");
  if (patch.width == 0 || patch.height == 0 || patch.heights.size() % patch.width != 0 ||
      patch.heights.size() / patch.width != patch.height)
    bad("width " + std::to_string(patch.width) + " x height " + std::to_string(patch.height) + " does not match " +
        std::to_string(patch.heights.size()) + " heights");
  if (!std::isfinite(patch.origin_x) || !std::isfinite(patch.origin_y))
    bad("origin is not finite");
  const double fi = (patch.origin_x - field.originX()) / field.dx();
  const double fj = (patch.origin_y - field.originY()) / field.dy();
  const double ri = std::round(fi), rj = std::round(fj);
  if (std::abs(fi - ri) > 1e-6 || std::abs(fj - rj) > 1e-6)
    bad("origin (" + std::to_string(patch.origin_x) + ", " + std::to_string(patch.origin_y) +
        ") is not on a grid point of the terrain");
  for (float h : patch.heights)
    if (!std::isfinite(h))
      bad("heights contain a non-finite value");
  if (std::abs(ri) > 1e15 || std::abs(rj) > 1e15)
    return std::nullopt;
  // Patch column c is grid column ri + c; keep the part inside the grid.
  const long i_first = std::max(0L, -static_cast<long>(ri));
  const long j_first = std::max(0L, -static_cast<long>(rj));
  const long i_end =
      std::min(static_cast<long>(patch.width), static_cast<long>(field.columns()) - static_cast<long>(ri));
  const long j_end = std::min(static_cast<long>(patch.height), static_cast<long>(field.rows()) - static_cast<long>(rj));
  if (i_first >= i_end || j_first >= j_end)
    return std::nullopt;
  const std::size_t w = static_cast<std::size_t>(i_end - i_first), h = static_cast<std::size_t>(j_end - j_first);
  std::vector<float> part(w * h);
  for (std::size_t r = 0; r < h; ++r)
    for (std::size_t c = 0; c < w; ++c)
      part[r * w + c] =
          patch.heights[(static_cast<std::size_t>(j_first) + r) * patch.width + static_cast<std::size_t>(i_first) + c];
  terrain::PointRange range;
  range.i0 = static_cast<std::size_t>(ri + i_first);
  range.j0 = static_cast<std::size_t>(rj + j_first);
  range.i1 = range.i0 + w - 1;
  range.j1 = range.j0 + h - 1;
  field.setHeights(range.i0, range.j0, w, h, part);
  return range;
}

}  // namespace sensors
}  // namespace avsp
