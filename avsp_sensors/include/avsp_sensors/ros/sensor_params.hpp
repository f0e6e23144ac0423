#pragma once
/**
 * @file sensor_params.hpp
 * @brief sensors_node's parameters (README.md, "sensors_node"): the vehicle list and each
 *        vehicle's sensor configuration read from XML-RPC values (what ros::NodeHandle::getParam
 *        returns for a YAML map), every key type-checked, unknown keys refused and every value
 *        checked by the core's validation, so a bad configuration names its key. No master needed:
 *        the functions take the values, not a NodeHandle.
 */
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <xmlrpcpp/XmlRpcValue.h>

#include "avsp_sensors/camera.hpp"
#include "avsp_sensors/ros/vehicle_frames.hpp"
#include "avsp_sensors/sensor_suite.hpp"

namespace avsp
{
namespace sensors
{
namespace node
{
/// One entry of ~vehicles (the same list dynamics_node reads; its x, y, yaw are ignored here).
struct VehicleEntry
{
  std::string name;   ///< namespace and frame prefix
  std::string model;  ///< config_dir/<model>.yaml
};

/**
 * @brief Reads ~vehicles: a non-empty list of {name, model} (x, y, yaw allowed and ignored),
 *        through the one parser every node uses (avsp::node::vehicleListParam).
 * @throw avsp::node::StartupError naming the entry and key: not a list, a missing or non-string
 *        name/model, an invalid or duplicate name, an unknown key
 */
std::vector<VehicleEntry> parseVehicles(const XmlRpc::XmlRpcValue& list);

/// Where an ultrasonic range finder sits: a URDF link of its name, or a pose in base_link that
/// the node publishes as a static transform.
struct UltrasonicMount
{
  std::optional<Eigen::Isometry3d> pose;  ///< base_link -> sensor; nullopt: the URDF link `name`
};

/**
 * @brief One vehicle's sensors as configured, before the vehicle's URDF gives the mounts: the
 *        core configuration (mounts identity) and the URDF link of each sensor.
 */
struct SensorsSpec
{
  SuiteConfig suite;
  std::string lidar_link = "lidar", radar_link = "radar", gps_link = "gps", imu_link = "imu";
  std::string magnetometer_link = "imu";
  std::vector<UltrasonicMount> ultrasonic_mounts;  ///< per suite.ultrasonics entry
  /// Cameras (section `cameras`), mounts in base_link from x..yaw; a stereo entry gives two.
  std::vector<CameraConfig> cameras;
  /// The magnetometer's geomagnetic model (`model`, loaded); nullopt with model 'fixed' or no
  /// magnetometer. placeMagnetometers() puts it on the map and the run's date.
  std::optional<GeomagneticModel> magnetometer_model;
  /// Parameter name of each section as read (e.g. "lidar" -> "~vehicle_sensors/ego/lidar").
  std::map<std::string, std::string> keys;
};

/**
 * @brief One vehicle's sensor configuration. Each section (lidar, radar, gps, imu,
 *        magnetometer, ultrasonic, occupancy, cameras) is taken from `vehicle` if it has it, else from
 *        `common`, else the defaults; `enabled: false` removes a sensor.
 * @param vehicle the vehicle's own map (~vehicle_sensors/<name>), or nullptr
 * @param vehicle_path its parameter name for messages, e.g. "~vehicle_sensors/ego"
 * @param common the map shared by all vehicles (~sensors), or nullptr
 * @param common_path e.g. "~sensors"
 * @throw avsp::node::StartupError naming the key ("parameter ~sensors/radar/max_range ...")
 */
SensorsSpec parseSensors(const XmlRpc::XmlRpcValue* vehicle, const std::string& vehicle_path,
                         const XmlRpc::XmlRpcValue* common, const std::string& common_path);

/**
 * @brief Puts each configured sensor on its URDF link (suite mounts from `frames`), checking
 *        that every link exists and each ultrasonic has either a link or a pose, not both.
 * @param where the vehicle, for messages, e.g. "vehicle 'ego' (model 'mrzr', ...)"
 * @throw avsp::node::StartupError "<where>: parameter <key>/frame = 'x' is not a link of <urdf>" and
 *        the ultrasonic rules' messages
 */
void mountSensors(SensorsSpec& spec, const VehicleFrames& frames, const std::string& where);

/// True when any vehicle of `specs` has a GPS or a magnetometer on a geomagnetic model (they
/// need the geodetic reference ~latitude, ~longitude).
bool needsOrigin(const std::vector<SensorsSpec>& specs);

/**
 * @brief Gives each magnetometer on a geomagnetic model (SensorsSpec::magnetometer_model) the
 *        model's field over the map on the run's date (MagnetometerConfig::model).
 * @param origin the map's geodetic reference (~latitude, ~longitude, ~altitude)
 * @param date the value of ~date: "YYYY-MM-DD" or a decimal year; "" when not set
 * @return a line for the log: the model, the date and the field's elements at the map origin
 *         ("" when no magnetometer uses a model)
 * @throw avsp::node::StartupError naming the parameters: ~date missing or malformed, a date or an
 *        origin's altitude outside the model's validity (e.g. "~sensors/magnetometer/model
 *        'wmm2025' on ~date '2031-01-01' at the map origin ...: wmm2025 (...) is valid for decimal
 *        years 2025.0 to 2030.0: the date is 2031.000"), no origin
 */
std::string placeMagnetometers(std::vector<SensorsSpec>& specs, const std::optional<EnuFrame>& origin,
                               const std::string& date);

}  // namespace node
}  // namespace sensors
}  // namespace avsp
