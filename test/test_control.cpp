// gtest of the controller core (avsp_control) against closed forms: pure pursuit curvature
// 2 sin(alpha) / L_d, the steering maps against avsp_dynamics' geometry and side mixing, the
// speed PID's step response (closed-form P loop, no windup under saturation), the speed
// profile's braking curves; a kinematic bicycle driven by the controllers converges to a
// straight line and a circle, holds each segment's speed and stops at the goal; breadcrumb
// gaps along a curved path; leader–follower gap and offset convergence; formation slots.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "avsp/control/leader_follower.hpp"
#include "avsp/control/path.hpp"
#include "avsp/control/pure_pursuit.hpp"
#include "avsp/control/speed_control.hpp"
#include "avsp/control/steering.hpp"
#include "avsp/control/waypoint_follower.hpp"
#include "avsp_dynamics/drivetrain.hpp"
#include "avsp_dynamics/vehicle_model.hpp"

namespace ac = avsp::control;

namespace
{
/// A 4x4-like Ackermann geometry: L = 3.3 m, full lock 0.5 rad, rear axle 1.65 m behind base_link.
ac::SteeringGeometry ackermann()
{
  ac::SteeringGeometry g;
  g.kind = ac::SteeringKind::kAckermann;
  g.wheelbase = 3.3;
  g.max_angle = 0.5;
  g.reference_x = -1.65;
  g.max_speed = 30.0;
  return g;
}

/**
 * Kinematic bicycle about the rear axle (the test's plant): x' = v cos(yaw), y' = v sin(yaw),
 * yaw' = v tan(delta) / L; delta follows steering * max_angle at a limited rate; the speed
 * obeys v' = a_throttle throttle - a_brake brake - drag v (no reverse).
 */
struct Bicycle
{
  ac::SteeringGeometry g = ackermann();
  double x = 0.0, y = 0.0, yaw = 0.0, v = 0.0, delta = 0.0;
  double max_rate = 0.8;    // rad/s
  double a_throttle = 2.5;  // m/s^2 at full throttle
  double a_brake = 6.0;     // m/s^2 at full brake
  double drag = 0.03;       // 1/s
  ac::Command command;

  ac::Pose2 base() const { return { x - g.reference_x * std::cos(yaw), y - g.reference_x * std::sin(yaw), yaw }; }
  ac::Vec2 rear() const { return { x, y }; }

  void step(double dt)
  {
    const double target = std::clamp(command.steering, -1.0, 1.0) * g.max_angle;
    delta += std::clamp(target - delta, -max_rate * dt, max_rate * dt);
    double a = a_throttle * command.throttle - drag * v;
    if (v > 0.0)
      a -= a_brake * command.brake;
    v = std::max(0.0, v + a * dt);
    x += v * std::cos(yaw) * dt;
    y += v * std::sin(yaw) * dt;
    yaw = ac::wrapAngle(yaw + v * std::tan(delta) / g.wheelbase * dt);
  }
};

constexpr double kPlantStep = 0.01;  // s
constexpr int kControlEvery = 5;     // controller at 20 Hz

/// Points of a circle of radius r about (cx, cy), counter-clockwise from angle a0 over `angle` rad.
std::vector<ac::Vec2> arc(double cx, double cy, double r, double a0, double angle, int n)
{
  std::vector<ac::Vec2> pts;
  for (int k = 0; k <= n; ++k)
  {
    const double a = a0 + angle * k / n;
    pts.push_back({ cx + r * std::cos(a), cy + r * std::sin(a) });
  }
  return pts;
}

std::vector<ac::Waypoint> withSpeed(const std::vector<ac::Vec2>& pts, double speed)
{
  std::vector<ac::Waypoint> w;
  for (const auto& p : pts)
    w.push_back({ p.x, p.y, speed });
  return w;
}
}  // namespace

// ---------------------------------------------------------------------------------------------
// Pure pursuit geometry

TEST(PurePursuit, CurvatureIsTwoSinAlphaOverLookahead)
{
  for (double yaw : { 0.0, 0.7, -2.5 })
    for (double alpha : { -1.2, -0.4, 0.0, 0.1, 0.5, 1.5 })
      for (double ld : { 2.0, 7.5, 20.0 })
      {
        const ac::Pose2 pose{ 3.0, -4.0, yaw };
        const ac::Vec2 target{ pose.x + ld * std::cos(yaw + alpha), pose.y + ld * std::sin(yaw + alpha) };
        const double k = ac::purePursuitCurvature(pose, target);
        EXPECT_NEAR(k, 2.0 * std::sin(alpha) / ld, 1e-12) << "yaw " << yaw << " alpha " << alpha << " L_d " << ld;
        if (std::abs(alpha) > 0.05)
        {
          // The arc tangent to the heading with that curvature passes through the target:
          // its centre lies 1/k to the left of the pose, at distance 1/|k| from the target.
          const double cx = pose.x - std::sin(yaw) / k, cy = pose.y + std::cos(yaw) / k;
          EXPECT_NEAR(std::hypot(target.x - cx, target.y - cy), 1.0 / std::abs(k), 1e-9);
        }
      }
  EXPECT_EQ(ac::purePursuitCurvature({ 1.0, 1.0, 0.3 }, { 1.0, 1.0 }), 0.0);
}

TEST(PurePursuit, LookaheadGrowsWithSpeedWithinBounds)
{
  ac::LookaheadOptions o;
  o.min = 4.0;
  o.gain = 0.8;
  o.max = 12.0;
  EXPECT_DOUBLE_EQ(ac::lookaheadDistance(o, 0.0), 4.0);
  EXPECT_DOUBLE_EQ(ac::lookaheadDistance(o, 5.0), 8.0);
  EXPECT_DOUBLE_EQ(ac::lookaheadDistance(o, -5.0), 8.0);
  EXPECT_DOUBLE_EQ(ac::lookaheadDistance(o, 50.0), 12.0);
  o.max = 3.0;
  EXPECT_THROW(ac::validate(o), std::invalid_argument);
  o.max = 12.0;
  o.min = 0.0;
  try
  {
    ac::validate(o);
    FAIL() << "lookahead_min 0 accepted";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("lookahead_min"), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------------------------------------
// Path

TEST(Path, ArcLengthProjectionOffsetsAndEndRay)
{
  ac::Path path({ { 0.0, 0.0 }, { 10.0, 0.0 }, { 10.0, 10.0 } });
  EXPECT_DOUBLE_EQ(path.length(), 20.0);
  EXPECT_DOUBLE_EQ(path.pointAt(15.0).y, 5.0);
  EXPECT_DOUBLE_EQ(path.pointAt(-3.0).x, 0.0);
  // Beyond the end: straight on along the last segment (north).
  EXPECT_NEAR(path.pointAt(25.0).x, 10.0, 1e-12);
  EXPECT_NEAR(path.pointAt(25.0).y, 15.0, 1e-12);
  // Offsets: + is left of the direction of travel.
  EXPECT_NEAR(path.offsetPointAt(5.0, 2.0).y, 2.0, 1e-12);
  EXPECT_NEAR(path.offsetPointAt(15.0, 2.0).x, 8.0, 1e-12);

  const ac::PathProjection p = path.project({ 4.0, -1.5 });
  EXPECT_NEAR(p.s, 4.0, 1e-12);
  EXPECT_NEAR(p.lateral, -1.5, 1e-12);                        // right of the path
  const ac::PathProjection q = path.project({ 11.0, 30.0 });  // beside the end ray
  EXPECT_NEAR(q.s, 40.0, 1e-12);
  EXPECT_NEAR(q.lateral, -1.0, 1e-12);
  // A window keeps the projection on its own part of the path.
  EXPECT_NEAR(path.project({ 9.0, 1.0 }, 0.0, 8.0).s, 8.0, 1e-12);

  // dropBefore keeps the arc lengths of the points left.
  path.dropBefore(12.0);
  EXPECT_EQ(path.size(), 2u);
  EXPECT_DOUBLE_EQ(path.startS(), 10.0);
  EXPECT_DOUBLE_EQ(path.pointAt(15.0).y, 5.0);

  // A moving tip.
  ac::Path crumbs;
  crumbs.moveBack({ 0.0, 0.0 });
  crumbs.moveBack({ 1.0, 0.0 });
  crumbs.moveBack({ 2.5, 0.0 });
  EXPECT_EQ(crumbs.size(), 2u);
  EXPECT_DOUBLE_EQ(crumbs.endS(), 2.5);
  crumbs.setEndHeading(M_PI / 2.0);
  EXPECT_NEAR(crumbs.pointAt(3.5).y, 1.0, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Steering maps

TEST(Steering, AckermannIsTheBicycleAngleOverFullLock)
{
  const ac::SteeringGeometry g = ackermann();
  for (double s : { -1.0, -0.5, -0.1, 0.0, 0.3, 0.9 })
  {
    const double k = ac::curvatureForSteering(g, s);
    EXPECT_NEAR(k, std::tan(s * 0.5) / 3.3, 1e-12);
    EXPECT_NEAR(ac::steeringForCurvature(g, k), s, 1e-12);
  }
  EXPECT_EQ(ac::steeringForCurvature(g, 10.0), 1.0);  // beyond full lock: clamped
  EXPECT_EQ(ac::steeringForCurvature(g, -10.0), -1.0);
  EXPECT_EQ(ac::throttleFeedforward(g, 5.0, 0.2), 0.0);
}

TEST(Steering, DifferentialMatchesSkidSteerSideMixing)
{
  ac::SteeringGeometry g;
  g.kind = ac::SteeringKind::kDifferential;
  g.effective_track_width = 0.62;
  g.max_speed = 2.0;
  for (double s : { -0.9, -0.5, -0.2, 0.1, 0.3, 0.5, 0.8 })
  {
    // Kinematic curvature of the centre from avsp_dynamics' side speeds (no side slip).
    const auto [left, right] = avsp::dynamics::skidSteerSides(0.6, s);
    const double v = (left + right) / 2.0;
    const double yaw_rate = (right - left) / g.effective_track_width;
    EXPECT_NEAR(ac::curvatureForSteering(g, s), yaw_rate / v, 1e-12) << "s " << s;
    EXPECT_NEAR(ac::steeringForCurvature(g, yaw_rate / v), s, 1e-12);
    // Feedforward: the outer side's fraction t that gives centre speed v_max * v.
    EXPECT_NEAR(ac::throttleFeedforward(g, v * g.max_speed, s), 0.6, 1e-12);
  }
  // s = 0.5 pivots about the inner side: radius B / 2.
  EXPECT_NEAR(ac::curvatureForSteering(g, 0.5), 2.0 / 0.62, 1e-12);
}

TEST(Steering, GeometryOfTheReferenceVehicles)
{
  namespace ad = avsp::dynamics;
  const std::string dir = std::string(AVSP_CONFIG_DIR) + "/vehicles/";
  const ad::VehicleModel fed = ad::loadVehicleModel(dir + "fed_alpha.yaml");
  const ac::SteeringGeometry g = ac::steeringGeometry(fed);
  EXPECT_EQ(g.kind, ac::SteeringKind::kAckermann);
  EXPECT_NEAR(g.wheelbase, 3.30, 1e-6);
  EXPECT_NEAR(g.reference_x, -1.65, 1e-6);  // rear axle, base_link midway between the axles
  const ad::AckermannGeometry ackermann_geometry(fed);
  EXPECT_DOUBLE_EQ(g.max_angle, ackermann_geometry.maxCentreAngle());
  EXPECT_LT(g.max_angle, fed.steering.max_angle);  // the inner wheel reaches max_angle first
  EXPECT_DOUBLE_EQ(g.max_speed, 30.0);

  const ac::SteeringGeometry t = ac::steeringGeometry(ad::loadVehicleModel(dir + "tracer_x.yaml"), 1.5);
  EXPECT_EQ(t.kind, ac::SteeringKind::kDifferential);
  EXPECT_NEAR(t.effective_track_width, 1.5 * 0.62, 1e-6);
  EXPECT_EQ(t.reference_x, 0.0);
  const ac::SteeringGeometry m = ac::steeringGeometry(ad::loadVehicleModel(dir + "m113.yaml"));
  EXPECT_EQ(m.kind, ac::SteeringKind::kDifferential);
  EXPECT_NEAR(m.effective_track_width, 2.30, 1e-6);
  EXPECT_THROW(ac::steeringGeometry(fed, 0.5), std::invalid_argument);
}

// The AVT-341 stack's vehicle parameters (config/avt_341_stack/<model>.yaml, loaded by
// launch/avt_341_stack.launch): its pure pursuit turns a curvature kappa into the steering
// s = atan(kappa L) / delta_max (clamped to [-1, 1]) with its own wheelbase L and full lock
// delta_max; AVSP turns s back into a curvature through the vehicle's model. The stack's
// curve must be the one AVSP drives: over the whole steering range for Ackermann vehicles, for
// gentle curves for skid-steer and tracked ones (their kinematics are not a bicycle's), with
// the effective track width the reference traverse steers them with.
TEST(Avt341StackParameters, TheStacksCurvatureIsTheOneAvspDrives)
{
  namespace ad = avsp::dynamics;
  const std::string config(AVSP_CONFIG_DIR);
  const YAML::Node traverse = YAML::LoadFile(config + "/scenarios/reference_traverse.yaml");
  for (const std::string model_name : { "fed_alpha", "mrzr", "tracer_x", "m113" })
  {
    SCOPED_TRACE(model_name);
    const ad::VehicleModel model = ad::loadVehicleModel(config + "/vehicles/" + model_name + ".yaml");
    const YAML::Node stack = YAML::LoadFile(config + "/avt_341_stack/" + model_name + ".yaml");
    const double L = stack["vehicle_control_node"]["vehicle_wheelbase"].as<double>();
    const double lock = stack["vehicle_control_node"]["vehicle_max_steer_angle_degrees"].as<double>() * M_PI / 180.0;
    double factor = 1.0;
    if (model.drive_type != ad::DriveType::kAckermann)
    {
      for (const YAML::Node& v : traverse["vehicles"])
        if (v["model"].as<std::string>() == model_name)
          factor = v["controller"]["params"]["track_width_factor"].as<double>();
      ASSERT_GT(factor, 1.0) << "the reference traverse steers every skid-steer or tracked vehicle with a factor";
    }
    const ac::SteeringGeometry avsp = ac::steeringGeometry(model, factor);
    // Skid-steer and tracked: up to kappa B = 0.2 (radius 5 B: 21 m for the carrier), where the
    // two maps part by about kappa B / 2 of the curvature (second order: AVSP's curvature is
    // 2 s / (B (1 - |s|)), the stack's s about kappa B / 2).
    const double B = avsp.effective_track_width;
    const double max_kappa = model.drive_type == ad::DriveType::kAckermann ? std::tan(lock) / L : 0.2 / B;
    for (int k = -10; k <= 10; ++k)
    {
      const double kappa = max_kappa * k / 10.0;
      const double s = std::clamp(std::atan(kappa * L) / lock, -1.0, 1.0);
      const double driven = ac::curvatureForSteering(avsp, s);
      if (model.drive_type == ad::DriveType::kAckermann)
        EXPECT_NEAR(driven, kappa, 5e-4 * std::abs(kappa) + 1e-12) << "kappa " << kappa;
      else
        EXPECT_NEAR(driven, kappa, 0.6 * kappa * kappa * B + 1e-12) << "kappa " << kappa;
    }
    // Gentle curves on a skid-steer or tracked vehicle: the slopes at kappa = 0 agree.
    const double tiny = 1e-6;
    EXPECT_NEAR(ac::curvatureForSteering(avsp, std::atan(tiny * L) / lock), tiny, 1e-3 * tiny);
    // No faster than the vehicle can go; the planner's width clears the vehicle's own.
    EXPECT_LE(stack["vehicle_control_node"]["vehicle_speed"].as<double>(), model.drivetrain.max_speed);
    double half_width = 0.0;
    for (const ad::WheelSpec& w : model.wheels)
      half_width = std::max(half_width, std::abs(w.rest_position.y()) + 0.5 * w.width);
    for (const ad::CollisionBox& b : model.collision_boxes)
      for (int corner = 0; corner < 8; ++corner)
      {
        const Eigen::Vector3d c =
            b.pose * Eigen::Vector3d((corner & 1 ? 0.5 : -0.5) * b.size.x(), (corner & 2 ? 0.5 : -0.5) * b.size.y(),
                                     (corner & 4 ? 0.5 : -0.5) * b.size.z());
        half_width = std::max(half_width, std::abs(c.y()));
      }
    if (model.drive_type == ad::DriveType::kTracked)
      half_width = std::max(half_width, 0.5 * (model.trackWidth() + model.track.shoe_width));
    const double width = stack["local_planner_node"]["vehicle_width"].as<double>();
    EXPECT_GE(width, 2.0 * half_width + 0.4);
    EXPECT_LE(width, 2.0 * half_width + 1.0);
  }
}

// ---------------------------------------------------------------------------------------------
// Speed PID and profile

TEST(SpeedPid, ProportionalLoopMatchesTheFirstOrderClosedForm)
{
  // Plant v' = a u - c v with u = kp (r - v) unsaturated: v(t) = v_inf (1 - exp(-t / tau)),
  // v_inf = a kp r / (c + a kp), tau = 1 / (c + a kp).
  ac::PidGains gains;
  gains.kp = 0.2;
  gains.ki = 0.0;
  ac::SpeedPid pid(gains);
  const double a = 2.0, c = 0.1, r = 2.0, dt = 1e-4;
  const double v_inf = a * gains.kp * r / (c + a * gains.kp), tau = 1.0 / (c + a * gains.kp);
  double v = 0.0;
  for (int k = 0; k < static_cast<int>(tau / dt); ++k)
  {
    const double u = pid.update(r, v, dt);
    ASSERT_LT(std::abs(u), 1.0);
    v += (a * u - c * v) * dt;
  }
  EXPECT_NEAR(v, v_inf * (1.0 - std::exp(-1.0)), 1e-3 * v_inf);
}

TEST(SpeedPid, LargeStepSaturatesWithoutWindup)
{
  // Plant v' = 2 u - 0.05 v, kp 0.3, ki 0.1. A 0.5 m/s step never saturates the effort: the
  // linear PI loop (s^2 + 0.65 s + 0.2, damping 0.73) overshoots by a fraction r of the step. A 10 m/s step
  // saturates the effort for seconds; without windup its overshoot is no larger a fraction.
  auto run = [](double step, bool anti_windup, double& overshoot, double& max_integral, double& final_error) {
    ac::PidGains gains;
    gains.kp = 0.3;
    gains.ki = 0.1;
    gains.anti_windup = anti_windup;
    ac::SpeedPid pid(gains);
    double v = 0.0;
    overshoot = 0.0;
    max_integral = 0.0;
    const double dt = 0.01;
    for (int k = 0; k < 6000; ++k)
    {
      const double u = pid.update(step, v, k == 0 ? 0.0 : dt);
      v += (2.0 * u - 0.05 * v) * dt;
      overshoot = std::max(overshoot, v - step);
      max_integral = std::max(max_integral, std::abs(pid.integralTerm()));
    }
    final_error = std::abs(v - step);
  };
  double linear = 0.0, integral = 0.0, error = 0.0;
  run(0.5, true, linear, integral, error);
  const double r = linear / 0.5;
  EXPECT_GT(r, 0.05);  // the linear loop overshoots (the PI zero at ki / kp adds to ζ = 0.73's)
  double overshoot = 0.0, max_integral = 0.0, final_error = 0.0;
  run(10.0, true, overshoot, max_integral, final_error);
  EXPECT_LE(overshoot / 10.0, r + 0.005) << "anti-windup PID overshoots more than its linear loop";
  EXPECT_LE(max_integral, 0.6 + 1e-12);
  EXPECT_LT(final_error, 0.01);
  // The same loop without anti-windup winds up: several times the linear loop's overshoot.
  double plain_overshoot = 0.0, plain_integral = 0.0, plain_error = 0.0;
  run(10.0, false, plain_overshoot, plain_integral, plain_error);
  EXPECT_GT(plain_overshoot / 10.0, 2.0 * r);
  EXPECT_GT(plain_overshoot, 5.0 * overshoot);
  EXPECT_GT(plain_integral, 1.5);
}

TEST(SpeedPid, OverSpeedBrakes)
{
  ac::PidGains gains;
  gains.kp = 0.3;
  ac::SpeedPid pid(gains);
  const ac::Pedals coast = ac::pedalsForEffort(pid.update(5.0, 5.1, 0.0), 0.05, 1.0);
  EXPECT_EQ(coast.throttle, 0.0);
  EXPECT_EQ(coast.brake, 0.0);  // 0.03 of effort: inside the coast band
  const ac::Pedals brake = ac::pedalsForEffort(pid.update(5.0, 7.0, 0.0), 0.05, 1.0);
  EXPECT_EQ(brake.throttle, 0.0);
  EXPECT_NEAR(brake.brake, 0.6 - 0.05, 1e-12);
  const ac::Pedals go = ac::pedalsForEffort(0.4, 0.05, 1.0);
  EXPECT_EQ(go.throttle, 0.4);
  EXPECT_EQ(go.brake, 0.0);
  EXPECT_EQ(ac::pedalsForEffort(std::nan(""), 0.05, 1.0).brake, 1.0);
  ac::PidGains bad;
  bad.integral_limit = 0.0;
  EXPECT_THROW(ac::SpeedPid{ bad }, std::invalid_argument);
}

TEST(SpeedProfile, SlowsDownAheadOfSlowerSegmentsAndTheGoal)
{
  // Waypoints at 0, 100, 200, 300 m with 8, 3, 6 m/s; a = 1 m/s^2.
  const ac::SpeedProfile p({ 0.0, 100.0, 200.0, 300.0 }, { 8.0, 3.0, 6.0 }, 1.0, 0.5);
  EXPECT_DOUBLE_EQ(p.targetSpeed(10.0), 8.0);
  // Braking curve into the 3 m/s segment: sqrt(9 + 2 * 1 * 10) 10 m before it.
  EXPECT_NEAR(p.targetSpeed(90.0), std::sqrt(29.0), 1e-12);
  EXPECT_NEAR(p.targetSpeed(100.0), 3.0, 1e-12);
  EXPECT_DOUBLE_EQ(p.targetSpeed(150.0), 3.0);
  EXPECT_DOUBLE_EQ(p.targetSpeed(201.0), 6.0);                // speeding up starts at the waypoint
  EXPECT_NEAR(p.targetSpeed(290.0), std::sqrt(20.0), 1e-12);  // towards the goal
  EXPECT_DOUBLE_EQ(p.targetSpeed(299.99), 0.5);               // creeping at the approach speed
  EXPECT_DOUBLE_EQ(p.segmentSpeed(150.0), 3.0);
  EXPECT_THROW(ac::SpeedProfile({ 0.0, 10.0 }, { -1.0 }, 1.0, 0.5), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// Waypoint follower on a kinematic bicycle

TEST(WaypointFollower, ConvergesToAStraightLine)
{
  ac::WaypointFollower follower(withSpeed({ { 0.0, 0.0 }, { 250.0, 0.0 } }, 6.0), ackermann(), {});
  Bicycle car;
  car.y = 3.0;  // 3 m left of the line, heading 17 deg away from it
  car.yaw = 0.3;
  double worst_late = 0.0;
  for (int k = 0; k < 40 / kPlantStep; ++k)
  {
    if (k % kControlEvery == 0)
      car.command = follower.update(car.base(), car.v, k * kPlantStep).command;
    car.step(kPlantStep);
    if (car.x > 100.0 && car.x < 200.0)
      worst_late = std::max(worst_late, std::abs(car.y));
  }
  EXPECT_GT(car.x, 200.0);
  EXPECT_LT(worst_late, 0.02) << "not on the line after 100 m";
  EXPECT_LT(std::abs(car.yaw), 0.005);
}

TEST(WaypointFollower, ConvergesToACircle)
{
  // 1.5 laps of a 30 m circle about (0, 30), counter-clockwise from the origin heading east.
  const double r = 30.0;
  ac::WaypointFollower follower(withSpeed(arc(0.0, r, r, -M_PI / 2.0, 3.0 * M_PI, 540), 5.0), ackermann(), {});
  Bicycle car;
  car.y = -3.0;  // starts 3 m outside the circle at its start (where it passes again a lap later)
  car.yaw = -0.2;
  double worst = 0.0, worst_speed = 0.0, angle_travelled = 0.0, last_angle = std::atan2(car.y - r, car.x);
  for (int k = 0; k < 60 / kPlantStep; ++k)
  {
    if (k % kControlEvery == 0)
      car.command = follower.update(car.base(), car.v, k * kPlantStep).command;
    car.step(kPlantStep);
    const double angle = std::atan2(car.y - r, car.x);
    angle_travelled += ac::wrapAngle(angle - last_angle);
    last_angle = angle;
    // Second lap: the rear axle (the reference point) on the circle.
    if (angle_travelled > 2.0 * M_PI && angle_travelled < 2.5 * M_PI)
    {
      worst = std::max(worst, std::abs(std::hypot(car.x, car.y - r) - r));
      worst_speed = std::max(worst_speed, std::abs(car.v - 5.0));
    }
  }
  ASSERT_GT(angle_travelled, 2.5 * M_PI) << "did not get round";
  // Pure pursuit's steady state on a circle is the circle itself (the pursued arc through a
  // point of the circle is the circle); the polygon's chords deviate by r (1 - cos(pi/360)).
  EXPECT_LT(worst, 0.05);
  EXPECT_LT(worst_speed, 0.05);
}

TEST(WaypointFollower, HoldsEachSegmentSpeedAndStopsAtTheGoal)
{
  // Segments at 6, 3 and 8 m/s over 100, 100 and 141 m, with a bend between the last two.
  std::vector<ac::Waypoint> w = { { 0.0, 0.0, 6.0 }, { 100.0, 0.0, 3.0 }, { 200.0, 0.0, 8.0 }, { 300.0, 100.0, 0.0 } };
  ac::WaypointFollowerOptions o;
  o.decel = 1.0;
  ac::WaypointFollower follower(w, ackermann(), o);
  Bicycle car;
  std::vector<std::vector<double>> speeds(3);
  bool arrived = false;
  double speed_entering_slow = 1e9;
  for (int k = 0; k < 150 / kPlantStep && !arrived; ++k)
  {
    if (k % kControlEvery == 0)
      car.command = follower.update(car.base(), car.v, k * kPlantStep).command;
    car.step(kPlantStep);
    const double s = follower.path().project({ car.base().x, car.base().y }).s;
    // The middle half of each segment.
    for (int seg = 0; seg < 3; ++seg)
    {
      const double s0 = follower.path().sAt(seg), s1 = follower.path().sAt(seg + 1);
      if (s > s0 + 0.25 * (s1 - s0) && s < s0 + 0.75 * (s1 - s0))
        speeds[seg].push_back(car.v);
    }
    if (std::abs(s - 100.0) < 0.5)
      speed_entering_slow = std::min(speed_entering_slow, car.v);
    arrived = follower.goalReached() && car.v < 1e-3;
  }
  ASSERT_TRUE(arrived) << "never stopped at the goal";
  const double target[3] = { 6.0, 3.0, 8.0 };
  for (int seg = 0; seg < 3; ++seg)
  {
    ASSERT_FALSE(speeds[seg].empty());
    double sum = 0.0;
    for (double v : speeds[seg])
      sum += v;
    EXPECT_NEAR(sum / speeds[seg].size(), target[seg], 0.02 * target[seg]) << "segment " << seg;
  }
  EXPECT_LT(speed_entering_slow, 3.0 * 1.1) << "entered the slow segment too fast";
  const ac::Pose2 end = car.base();
  EXPECT_LT(std::hypot(end.x - 300.0, end.y - 100.0), o.goal_tolerance + 0.3);
  // Once there it stays braked.
  EXPECT_EQ(follower.update(car.base(), 0.0, 1000.0).command.brake, 1.0);
}

TEST(WaypointFollower, BadWaypointsNameTheEntryAndKey)
{
  auto message = [](const std::vector<ac::Waypoint>& w) {
    try
    {
      ac::validateWaypoints(w);
    }
    catch (const std::invalid_argument& e)
    {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(message({ { 0.0, 0.0, 1.0 } }).find("at least 2"), std::string::npos);
  EXPECT_NE(message({ { 0.0, 0.0, 1.0 }, { 5.0, 0.0, 2.0 }, { 9.0, 0.0, -1.0 } }).find("waypoints[2].speed"),
            std::string::npos);
  EXPECT_NE(message({ { 0.0, 0.0, 0.0 }, { 5.0, 0.0, 2.0 } }).find("waypoints[0].speed"), std::string::npos);
  EXPECT_NE(message({ { 0.0, 0.0, 1.0 }, { 0.0, std::nan(""), 2.0 } }).find("waypoints[1].y"), std::string::npos);
  EXPECT_NE(message({ { 0.0, 0.0, 1.0 }, { 0.0, 0.0, 2.0 } }).find("waypoints[1]"), std::string::npos);
  EXPECT_EQ(message({ { 0.0, 0.0, 1.0 }, { 5.0, 0.0, 0.0 } }), "accepted");
}

// ---------------------------------------------------------------------------------------------
// Leader–follower

TEST(LeaderFollower, GapIsTheDistanceAlongACurvedPath)
{
  // The leader drives a 20 m circle at 5 m/s, broadcasting at 10 Hz (0.5 m of arc apart);
  // the follower sits where the leader started. A quarter turn later the gap is 20 pi / 2.
  const double r = 20.0, v = 5.0;
  ac::LeaderFollowerOptions o;
  ac::LeaderFollower f(ackermann(), o);
  const ac::Pose2 follower{ r, 0.0, M_PI / 2.0 };  // on the circle about the origin, heading north
  f.update(follower, 0.0, 0.0);
  double last_stamp = 0.0, leader_angle = 0.0;
  for (int k = 0; k * v * 0.1 / r <= M_PI / 2.0; ++k)
  {
    last_stamp = 0.1 * k;
    leader_angle = k * v * 0.1 / r;
    ASSERT_TRUE(f.addLeaderState(
        { last_stamp, r * std::cos(leader_angle), r * std::sin(leader_angle), leader_angle + M_PI / 2.0, v }));
  }
  ac::FollowerStatus st = f.update(follower, 0.0, last_stamp);
  EXPECT_TRUE(st.leader_fresh);
  // Chords of 0.5 m on a 20 m circle are 1.3e-5 m shorter than their arcs.
  EXPECT_NEAR(st.gap, r * leader_angle, 0.01);
  // A broadcast 0.2 s old: the leader is predicted 0.2 v further on.
  const double fresh_gap = st.gap;
  st = f.update(follower, 0.0, last_stamp + 0.2);
  EXPECT_NEAR(st.gap - fresh_gap, 0.2 * v, 1e-9);
  // Past leader_timeout: braking, whatever the gap.
  st = f.update(follower, 0.0, last_stamp + 1.5);
  EXPECT_FALSE(st.leader_fresh);
  EXPECT_EQ(st.tracking.command.brake, 1.0);
  EXPECT_EQ(st.tracking.command.throttle, 0.0);
  EXPECT_FALSE(f.addLeaderState({ last_stamp + 2.0, std::nan(""), 0.0, 0.0, 1.0 }));
}

namespace
{
/// Leader on waypoints, follower on the leader's 10 Hz broadcasts, both kinematic bicycles
/// with controllers at 20 Hz. `truth` records the leader's rear-axle path every plant step
/// (a path independent of the follower's breadcrumbs) to measure the gap along it.
struct Convoy
{
  ac::WaypointFollower leader_ctl;
  ac::LeaderFollower follower_ctl;
  Bicycle leader, follower;
  ac::Path truth;
  double t = 0.0;
  int k = 0;
  double broadcast_speed = 0.0;

  Convoy(const std::vector<ac::Waypoint>& route, const ac::LeaderFollowerOptions& o)
    : leader_ctl(route, ackermann(), {}), follower_ctl(ackermann(), o)
  {
  }

  ac::Vec2 baseOf(const Bicycle& b) const { return { b.base().x, b.base().y }; }

  void run(double until)
  {
    for (; t < until; ++k, t = k * kPlantStep)
    {
      if (k % 10 == 0)  // 10 Hz broadcasts, acceleration over the broadcast period
      {
        follower_ctl.addLeaderState(
            { t, leader.base().x, leader.base().y, leader.yaw, leader.v, (leader.v - broadcast_speed) / 0.1 });
        broadcast_speed = leader.v;
      }
      if (k % kControlEvery == 0)
      {
        leader.command = leader_ctl.update(leader.base(), leader.v, t).command;
        follower.command = follower_ctl.update(follower.base(), follower.v, t).tracking.command;
      }
      leader.step(kPlantStep);
      follower.step(kPlantStep);
      truth.append(baseOf(leader));
    }
  }

  /// Gap along the leader's true path, base_link to base_link.
  double trueGap() const { return truth.endS() - truth.project(baseOf(follower)).s; }
};
}  // namespace

TEST(LeaderFollower, KeepsTheGapThroughABendAndFollowsAGapChange)
{
  // East 120 m, a 90 deg left bend of 40 m radius, north 300 m, at 5 m/s.
  std::vector<ac::Vec2> pts = { { 0.0, 0.0 } };
  for (const ac::Vec2& p : arc(120.0, 40.0, 40.0, -M_PI / 2.0, M_PI / 2.0, 60))
    pts.push_back(p);
  pts.push_back({ 160.0, 400.0 });
  ac::LeaderFollowerOptions o;
  o.gap = 10.0;
  Convoy c(withSpeed(pts, 5.0), o);
  c.leader.x = 12.0;  // the follower starts 12 m + 0 behind, at rest, in line
  c.truth.append(c.baseOf(c.follower));
  c.run(30.0);
  double worst_gap = 0.0, worst_lateral = 0.0;
  for (double until = 30.0; until < 70.0; until += 0.5)  // through the bend
  {
    c.run(until);
    worst_gap = std::max(worst_gap, std::abs(c.trueGap() - 10.0));
    worst_lateral = std::max(worst_lateral, c.truth.project(c.baseOf(c.follower)).distance);
  }
  EXPECT_LT(worst_gap, 0.3);
  EXPECT_LT(worst_lateral, 0.3) << "the follower left the leader's tracks";
  // Gap 10 -> 20 m at run time: converges within 30 s.
  c.follower_ctl.setGap(20.0);
  c.run(100.0);
  EXPECT_NEAR(c.trueGap(), 20.0, 0.2);
  EXPECT_NEAR(c.follower.v, 5.0, 0.1);
  EXPECT_THROW(c.follower_ctl.setGap(-1.0), std::invalid_argument);
  EXPECT_THROW(c.follower_ctl.setOffset(std::nan("")), std::invalid_argument);
}

TEST(LeaderFollower, NormalOffsetOnAStraightAndOnACircle)
{
  // Line formation on a straight: abreast (gap 0), 4 m to the left.
  {
    ac::LeaderFollowerOptions o;
    o.gap = 0.0;
    o.offset = 4.0;
    Convoy c(withSpeed({ { 0.0, 0.0 }, { 600.0, 0.0 } }, 5.0), o);
    c.leader.x = 5.0;
    c.follower.y = 1.0;
    c.run(60.0);
    EXPECT_NEAR(c.follower.y, 4.0, 0.05);
    EXPECT_NEAR(c.follower.base().x, c.leader.base().x, 0.3);
  }
  // Diamond-style slot on a 30 m circle turning left: 8 m behind, 4 m to the right (outside).
  {
    const double r = 30.0;
    ac::LeaderFollowerOptions o;
    o.gap = 8.0;
    o.offset = -4.0;
    Convoy c(withSpeed(arc(0.0, r, r, -M_PI / 2.0, 4.0 * M_PI, 720), 4.0), o);
    c.leader.x = 10.0;
    c.leader.y = 1.7;  // roughly on the circle
    c.leader.yaw = 0.33;
    c.follower.y = -4.0;
    c.run(60.0);
    double worst = 0.0;
    for (double until = 60.0; until < 80.0; until += 0.5)
    {
      c.run(until);
      worst = std::max(worst, std::abs(std::hypot(c.follower.x, c.follower.y - r) - (r + 4.0)));
    }
    EXPECT_LT(worst, 0.1);
  }
}

TEST(Formation, SlotsOfColumnLineAndDiamond)
{
  const auto column = ac::formationSlots(ac::FormationType::kColumn, 3, 15.0, 5.0);
  ASSERT_EQ(column.size(), 3u);
  EXPECT_EQ(column[0].leader, -1);
  EXPECT_EQ(column[1].leader, 0);
  EXPECT_EQ(column[2].leader, 1);
  EXPECT_EQ(column[2].gap, 15.0);
  EXPECT_EQ(column[2].offset, 0.0);

  const auto line = ac::formationSlots(ac::FormationType::kLine, 5, 15.0, 5.0);
  const double line_offsets[] = { 0.0, -5.0, 5.0, -10.0, 10.0 };
  for (int k = 1; k < 5; ++k)
  {
    EXPECT_EQ(line[k].leader, 0);
    EXPECT_EQ(line[k].gap, 0.0);
    EXPECT_EQ(line[k].offset, line_offsets[k]);
  }

  const auto diamond = ac::formationSlots(ac::FormationType::kDiamond, 5, 10.0, 4.0);
  EXPECT_EQ(diamond[1].leader, 0);
  EXPECT_EQ(diamond[1].offset, 4.0);
  EXPECT_EQ(diamond[2].offset, -4.0);
  EXPECT_EQ(diamond[1].gap, 10.0);
  EXPECT_EQ(diamond[3].leader, 0);
  EXPECT_EQ(diamond[3].gap, 20.0);
  EXPECT_EQ(diamond[3].offset, 0.0);
  EXPECT_EQ(diamond[4].leader, 3);

  EXPECT_EQ(ac::formationFromString("diamond"), ac::FormationType::kDiamond);
  EXPECT_THROW(ac::formationFromString("wedge"), std::invalid_argument);
  EXPECT_THROW(ac::formationSlots(ac::FormationType::kLine, 0, 10.0, 4.0), std::invalid_argument);
  EXPECT_THROW(ac::formationSlots(ac::FormationType::kLine, 3, 10.0, -4.0), std::invalid_argument);
}

TEST(LeaderFollower, BadOptionsNameTheField)
{
  ac::LeaderFollowerOptions o;
  o.gap = -2.0;
  try
  {
    ac::LeaderFollower f(ackermann(), o);
    FAIL() << "negative gap accepted";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_EQ(std::string(e.what()).rfind("gap", 0), 0u) << e.what();
  }
  o = {};
  o.tracking.pid.kp = -1.0;
  EXPECT_THROW(ac::LeaderFollower(ackermann(), o), std::invalid_argument);
  ac::SteeringGeometry g = ackermann();
  g.max_angle = 2.0;
  EXPECT_THROW(ac::LeaderFollower(g, {}), std::invalid_argument);
}
