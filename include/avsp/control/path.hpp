#pragma once
/**
 * @file path.hpp
 * @brief A planar polyline with arc length, the geometry both controllers pursue (no ROS).
 *
 * Points are in the map frame (m). Arc length s is measured from the path's first point
 * ever: dropping points from the front (dropBefore, for a leader's breadcrumbs) keeps the
 * s of every remaining point, so distances along the path stay comparable over time.
 * Beyond the last point the path continues as a straight ray along its end heading (the
 * last segment's direction unless set), so a lookahead point past the end, or a vehicle
 * beside the end of a path, still has a well-defined place on it.
 */
#include <cstddef>
#include <limits>
#include <vector>

namespace avsp
{
namespace control
{
/// A point or vector in the map plane, m.
struct Vec2
{
  double x = 0.0;
  double y = 0.0;
};

/// A planar pose: position (m, map) and heading (rad, 0 = east, counter-clockwise +).
struct Pose2
{
  double x = 0.0;
  double y = 0.0;
  double yaw = 0.0;
};

/// The nearest place on a path to a point.
struct PathProjection
{
  double s = 0.0;         ///< m, arc length of the nearest point (may exceed endS() on the end ray)
  Vec2 point;             ///< m, the nearest point
  double lateral = 0.0;   ///< m, signed distance of the query point from the path, + = left of it
  double distance = 0.0;  ///< m, |lateral| (or the distance to the first point before the start)
};

/// A polyline with arc length, an end ray, and normal offsets.
class Path
{
public:
  Path() = default;

  /**
   * @brief A path through `points` in order; a point closer than 1 mm to the previous one
   *        is skipped.
   */
  explicit Path(const std::vector<Vec2>& points);

  /// Appends `p` unless it is within 1 mm of the last point.
  void append(const Vec2& p);

  /**
   * @brief Moves the last point to `p` (a breadcrumb tip following its vehicle); appends it
   *        when the path is empty. With two or more points, `p` must not coincide with the
   *        point before it (then the tip is dropped until it moves away).
   */
  void moveBack(const Vec2& p);

  /// Drops leading points while the next one is at or before arc length `s` (s stays as it was).
  void dropBefore(double s);

  /// Sets the direction (rad) of the ray that continues the path beyond its last point.
  void setEndHeading(double heading);

  std::size_t size() const { return points_.size(); }
  bool empty() const { return points_.empty(); }
  const std::vector<Vec2>& points() const { return points_; }
  double startS() const { return s_.empty() ? 0.0 : s_.front(); }  ///< m, arc length of the first point
  double endS() const { return s_.empty() ? 0.0 : s_.back(); }     ///< m, arc length of the last point
  double length() const { return endS() - startS(); }              ///< m
  double sAt(std::size_t index) const { return s_.at(index); }     ///< m, arc length of point `index`

  /// Direction of the end ray (rad): the set end heading, else the last segment's (0 with < 2 points).
  double endHeading() const;

  /// Point at arc length s: clamped to the first point below startS(), on the end ray beyond endS().
  Vec2 pointAt(double s) const;

  /// Heading (rad) of the path at arc length s: of its segment, of the end ray beyond endS().
  double headingAt(double s) const;

  /// pointAt(s) moved `offset` m along the left normal at s (+ left of the direction of travel).
  Vec2 offsetPointAt(double s, double offset) const;

  /**
   * @brief The nearest point of the path (segments and the end ray) to `p` with arc length
   *        in [s_min, s_max]. Requires a non-empty path.
   * @param s_min, s_max window of arc length searched (m); the defaults search everything.
   *        A window keeps a vehicle on its own part of a path that loops back on itself.
   */
  PathProjection project(const Vec2& p, double s_min = std::numeric_limits<double>::lowest(),
                         double s_max = std::numeric_limits<double>::max()) const;

  /**
   * @brief Where a vehicle joins a path that may pass the same place more than once: the
   *        earliest passage whose nearest point is at most `slack` m farther from `p` than
   *        the nearest of all (passages at least `separation` m of arc length apart).
   */
  PathProjection projectFirst(const Vec2& p, double slack = 1.0, double separation = 10.0) const;

private:
  /// Index of the segment [i, i+1] holding arc length s (size() - 2 beyond the end).
  std::size_t segmentAt(double s) const;

  std::vector<Vec2> points_;
  std::vector<double> s_;
  bool has_end_heading_ = false;
  double end_heading_ = 0.0;
};

/// Wraps an angle to (-pi, pi].
double wrapAngle(double angle);

}  // namespace control
}  // namespace avsp
