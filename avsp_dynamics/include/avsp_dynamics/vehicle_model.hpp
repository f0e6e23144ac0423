#pragma once
/**
 * @file vehicle_model.hpp
 * @brief A vehicle's description as the dynamics uses it: bodies, wheels or tracks and
 *        their joints from the URDF, and the parameters URDF cannot hold (suspension,
 *        steering, drivetrain, brakes) from config/vehicles/<model>.yaml. Everything is
 *        validated at load; a bad file throws ConfigError naming the file and the key.
 */
#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace avsp
{
namespace dynamics
{
/// A vehicle description that cannot be used; what() names the file and key/link/joint.
class ConfigError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

enum class DriveType
{
  kAckermann,  ///< steered front wheels (steering joints), driven axles
  kSkidSteer,  ///< no steering joints; steering becomes a left/right speed difference
  kTracked,    ///< two tracks; steering becomes a left/right sprocket speed difference
  kLegged      ///< legs of three revolute joints each (abduction, hip flexion, knee), feet on the soil
};

enum class Differential
{
  kOpen,
  kLocked
};

/// A URDF link that carries mass.
struct Body
{
  std::string link;
  double mass;                        ///< kg, > 0
  Eigen::Vector3d principal_inertia;  ///< kg m^2, eigenvalues of the inertia tensor
  Eigen::Vector3d rest_position;      ///< m, link origin in base_link with all joints at 0
  Eigen::Vector3d com;                ///< m, centre of mass in base_link with all joints at 0
  Eigen::Matrix3d inertia;            ///< kg m^2, about the centre of mass, in base_link axes
};

/// A box of a chassis link's URDF <collision>: what collides with obstacles and other vehicles.
struct CollisionBox
{
  std::string link;                                        ///< the URDF link it belongs to
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  ///< box centre and axes in base_link at the rest pose
  Eigen::Vector3d size = Eigen::Vector3d::Zero();          ///< m, full edge lengths along the box's own x, y, z (> 0)
};

/// A road wheel of a wheeled vehicle, with its suspension and (optional) steering joints.
struct WheelSpec
{
  std::string name;              ///< e.g. front_left
  std::string spin_joint;        ///< continuous joint about the wheel axle (URDF y)
  std::string suspension_joint;  ///< prismatic joint along base z
  std::string steering_joint;    ///< revolute joint about z; empty if not steered
  std::string link;              ///< the wheel link (child of spin_joint)
  bool driven;
  double radius;                  ///< m, from the wheel link's collision cylinder
  double width;                   ///< m, from the wheel link's collision cylinder
  double suspension_lower;        ///< m, URDF joint lower limit (< 0), along base z
  double suspension_upper;        ///< m, URDF joint upper limit (> 0), along base z
  Eigen::Vector3d rest_position;  ///< m, wheel centre in base_link with all joints at 0
};

/// One road wheel of a track on its torsion-bar arm.
struct RoadWheelSpec
{
  std::string arm_joint;          ///< revolute joint about y (torsion bar)
  std::string spin_joint;         ///< continuous joint about y
  std::string arm_link;           ///< the road arm link (child of arm_joint)
  std::string link;               ///< the road wheel link
  double radius;                  ///< m
  double width;                   ///< m
  Eigen::Vector3d rest_position;  ///< m, wheel centre in base_link
  Eigen::Vector3d pivot;          ///< m, arm_joint's origin (the torsion bar's axis) in base_link
  double arm_axis_sign = 1.0;     ///< +1 if arm_joint's axis is +y of base_link, -1 if -y
  double arm_lower = 0.0;         ///< rad, arm_joint's lower limit (its own sign convention)
  double arm_upper = 0.0;         ///< rad, arm_joint's upper limit
};

/// One side's track running gear.
struct TrackSpec
{
  std::string side;  ///< left | right
  std::string sprocket_joint;
  std::string idler_joint;
  std::string sprocket_link;               ///< child of sprocket_joint
  std::string idler_link;                  ///< child of idler_joint
  std::string belt_link;                   ///< link holding the track belt's mass, fixed to the hull
  double sprocket_radius;                  ///< m, URDF sprocket cylinder radius
  double idler_radius;                     ///< m
  std::vector<RoadWheelSpec> road_wheels;  ///< front to rear
  /// m, ground contact length: first to last road wheel centre along x.
  double contactLength() const;
};

/// Track shoe parameters shared by both sides (docs/MODELS.md T10).
struct TrackParameters
{
  double pitch = 0.0;       ///< m
  int sprocket_teeth = 0;   ///< N
  double shoe_width = 0.0;  ///< m
  /// Internal (running gear) resistance of each track: (coefficient + per_speed |v|) times
  /// the track's share of the weight, against the belt's motion relative to the hull.
  double internal_resistance = 0.0;            ///< fraction of the weight
  double internal_resistance_per_speed = 0.0;  ///< fraction of the weight per m/s
  /// m, track speed per sprocket rad/s: p N / (2 pi) (T10).
  double effectiveSprocketRadius() const;
};

/// One actuated joint kind of a legged vehicle (every leg's joint of that kind alike).
struct LegJointSpec
{
  double lower = 0.0;       ///< rad, the simulated range (within the URDF joint's limits)
  double upper = 0.0;       ///< rad
  double max_torque = 0.0;  ///< N m, the actuator's peak
  double max_speed = 0.0;   ///< rad/s: the available torque falls linearly to 0 at it, driving faster
  double stiffness = 0.0;   ///< N m/rad, the joint PD's proportional gain
  double damping = 0.0;     ///< N m s/rad, its derivative gain
};

/// A leg: three revolute joints in a chain from base_link, the foot fixed at its end.
struct LegSpec
{
  std::string name;             ///< e.g. front_left
  std::string joints[3];        ///< abduction (about base x), hip flexion, knee (about y)
  std::string links[3];         ///< their child links: hip, thigh, shank
  std::string foot_link;        ///< fixed to the shank; its <collision> sphere is the foot
  Eigen::Vector3d anchors[3];   ///< m, each joint's origin in base_link with all joints at 0
  Eigen::Vector3d axes[3];      ///< unit, each joint's axis in base_link with all joints at 0
  Eigen::Vector3d foot_centre;  ///< m, the foot sphere's centre in base_link with all joints at 0
  double foot_radius = 0.0;     ///< m
};

/// What the URDF cannot say about a legged vehicle.
struct LeggedSpec
{
  LegJointSpec joints[3];      ///< abduction, flexion, knee
  double stance_height = 0.0;  ///< m, base_link above the soles standing
  bool knees_backward = true;  ///< the knee points backwards (its angle < 0 with +y axes)
  double pad_size = 0.0;       ///< m, side of the square pad under each foot (the soil's footprint)
};

struct SuspensionSpec  ///< wheeled: linear spring-damper per wheel
{
  double stiffness = 0.0;           ///< N/m
  double damping = 0.0;             ///< N s/m
  double preload_deflection = 0.0;  ///< m
};

struct TorsionSuspensionSpec  ///< tracked: torsion bar per road arm
{
  double torsion_stiffness = 0.0;  ///< N m/rad
  double torsion_damping = 0.0;    ///< N m s/rad
  double preload_angle = 0.0;      ///< rad
};

struct SteeringSpec
{
  double max_angle = 0.0;  ///< rad, road-wheel angle at full lock (ackermann only)
  double max_rate = 0.0;   ///< rad/s
};

struct DrivetrainSpec
{
  double engine_max_torque = 0.0;                     ///< N m
  double engine_max_power = 0.0;                      ///< W
  double gear_ratio = 0.0;                            ///< engine : wheel (or sprocket)
  double efficiency = 0.0;                            ///< (0, 1]
  double max_speed = 0.0;                             ///< m/s
  double reverse_max_speed = 0.0;                     ///< m/s, governed speed in reverse (<= max_speed)
  std::map<std::string, Differential> differentials;  ///< front/rear/center or left/right
};

/// The running gear on rigid surfaces (soils of model rigid): a brush-model tyre, or a track's
/// rubber pads under one road wheel.
struct FirmGroundSpec
{
  double vertical_stiffness = 0.0;      ///< N/m per wheel (per road wheel of a track)
  double longitudinal_stiffness = 0.0;  ///< C_x / F_z: longitudinal slip stiffness per unit slip
  double cornering_stiffness = 0.0;     ///< C_alpha / F_z: cornering stiffness per rad
  double relaxation_length = 0.0;       ///< m: how far it rolls for its slip to build up
};

struct BrakeSpec
{
  double max_torque = 0.0;  ///< N m per wheel (or sprocket)
};

/// Everything the dynamics needs to build one vehicle.
struct VehicleModel
{
  std::string model;  ///< e.g. fed_alpha
  DriveType drive_type;
  std::string yaml_path;
  std::string urdf_path;  ///< resolved, absolute or relative to the working directory
  std::vector<Body> bodies;
  double total_mass = 0.0;        ///< kg, sum of bodies
  std::vector<WheelSpec> wheels;  ///< wheeled vehicles
  std::vector<TrackSpec> tracks;  ///< tracked vehicles: left then right
  std::vector<LegSpec> legs;      ///< legged vehicles, in the YAML's order
  LeggedSpec legged;              ///< legged vehicles
  TrackParameters track;
  SuspensionSpec suspension;
  TorsionSuspensionSpec torsion;
  SteeringSpec steering;
  DrivetrainSpec drivetrain;
  BrakeSpec brakes;
  FirmGroundSpec firm_ground;
  std::map<std::string, Eigen::Vector3d> sensor_mounts;  ///< lidar/radar/gps/imu, m in base_link
  /// The <collision> boxes of every link that is not running gear (wheels, road wheels,
  /// sprockets, idlers: their cylinders are the running gear's), at least one.
  std::vector<CollisionBox> collision_boxes;

  /// m, front-axle x minus rear-axle x (wheeled), track contact length (tracked), or the hip
  /// flexion joints' spread along x (legged: the feet's at stance).
  double wheelbase() const;
  /// m, left-right distance between wheel (or track) centres, or the feet's at stance (legged).
  double trackWidth() const;
};

/// Sensor mount links every vehicle URDF must have, attached by fixed joints.
const std::vector<std::string>& requiredSensorLinks();

/// Largest vehicle file (YAML or URDF) read: the reference URDFs are 8-21 kB; a bigger file is
/// not a vehicle description, and reading it would only cost memory.
constexpr std::uint64_t kMaxVehicleFileBytes = 16u << 20;  // 16 MiB

/**
 * @brief Loads config/vehicles/<model>.yaml and the URDF it names, and validates both.
 * @param yaml_path the vehicle's YAML file; its `urdf` key is relative to this file's folder
 * @return the validated model
 * @throw ConfigError naming the file and the key, link or joint at fault and why
 */
VehicleModel loadVehicleModel(const std::string& yaml_path);

/// The running gear that meets the ground, wheels then road wheels (left track, then right), or
/// a legged vehicle's feet where its stance puts them: each one's centre in base_link at rest
/// and its radius (m).
std::vector<std::pair<Eigen::Vector3d, double>> runningGear(const VehicleModel& model);

const char* toString(DriveType type);

}  // namespace dynamics
}  // namespace avsp
