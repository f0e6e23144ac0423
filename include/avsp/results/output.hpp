#pragma once
/**
 * @file output.hpp
 * @brief The run recorder's files (no ROS): a small JSON document builder, CSV tables and
 *        NumPy .npy grids, written atomically enough for a results folder (each file is
 *        complete when its writer returns; a failure throws naming the file).
 */
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "avsp/results/gap.hpp"
#include "avsp/results/rut_map.hpp"
#include "avsp/results/vehicle_record.hpp"

namespace avsp
{
namespace results
{
/// A JSON value: null, bool, number, string, array or object (keys kept in insertion order).
class Json
{
public:
  Json() = default;     ///< null
  Json(bool b);         ///< NOLINT: implicit on purpose, like a JSON literal
  Json(double number);  ///< NaN and infinities become null (JSON has none)
  Json(int number) : Json(static_cast<double>(number)) {}
  Json(std::uint32_t number) : Json(static_cast<double>(number)) {}
  Json(std::size_t number) : Json(static_cast<double>(number)) {}
  Json(const char* text);
  Json(const std::string& text);
  template <typename T>
  Json(const std::optional<T>& value) : Json(value ? Json(*value) : Json())
  {
  }

  static Json array();
  static Json object();
  /// Appends to an array. @throw std::logic_error if this is not an array
  Json& push(Json value);
  /// Sets an object's key (replacing it). @throw std::logic_error if this is not an object
  Json& set(const std::string& key, Json value);

  /// The document, indented by two spaces per level; numbers with up to 10 significant digits.
  std::string dump(int indent = 2) const;

private:
  enum class Kind
  {
    kNull,
    kBool,
    kNumber,
    kString,
    kArray,
    kObject
  };
  void write(std::string& out, int indent, int level) const;

  Kind kind_ = Kind::kNull;
  bool bool_ = false;
  double number_ = 0.0;
  std::string string_;
  std::vector<Json> items_;
  std::vector<std::pair<std::string, Json>> members_;
};

/// JSON string literal of `text` (quotes, backslashes and control characters escaped).
std::string jsonQuote(const std::string& text);

/// Writes `text` to `path`. @throw std::runtime_error naming the file and the reason
void writeText(const std::string& path, const std::string& text);

/**
 * @brief A float32 NumPy array file (.npy, version 1.0, little-endian, shape (height, width),
 *        C order: row j is map y = origin_y + j resolution) of a grid's values.
 * @throw std::runtime_error naming the file
 */
void writeNpy(const std::string& path, const Grid& grid);

/// A grid's geometry for grids.json: file, origin_x/origin_y (cell centres), resolution, width, height.
Json gridJson(const std::string& file, const Grid& grid);

/**
 * @brief A CSV table written as the run goes, in constant memory: each group's rows (a vehicle's,
 *        a follower's) are appended to its own spool file in `spool_dir` (`.<stem>.<k>.part`,
 *        removed with the table); write() puts the header and every group's rows, in group order,
 *        into the table's file, so the file does not depend on how the groups' messages interleave.
 */
class SpooledTable
{
public:
  /// @throw std::runtime_error naming a spool file that cannot be created
  SpooledTable(const std::string& spool_dir, const std::string& stem, const std::string& header, std::size_t groups);
  ~SpooledTable();
  SpooledTable(const SpooledTable&) = delete;
  SpooledTable& operator=(const SpooledTable&) = delete;

  /// Appends a row ("...\n") to group `k`. @throw std::runtime_error naming the spool file
  void add(std::size_t k, const std::string& row);
  /// Rows added to group `k`.
  std::size_t rows(std::size_t k) const;
  /// Writes the header and every group's rows to `path` (the spools stay for a later write).
  /// @param extra a last row per group ("" = none), written after that group's rows
  /// @throw std::runtime_error naming the file
  void write(const std::string& path, const std::vector<std::string>& extra = {});

private:
  struct Group;
  std::string header_;
  std::vector<std::unique_ptr<Group>> groups_;
};

/**
 * @brief trajectories.csv: `vehicle,t,x,y,z,speed,distance` (s, m, m, m, m/s, m), each vehicle's
 *        first sample, its first at or after each multiple of `period` (s), and its last sample.
 */
class TrajectoryTable
{
public:
  /// @throw std::invalid_argument if period is not > 0; std::runtime_error naming a spool file
  TrajectoryTable(const std::string& spool_dir, const std::vector<std::string>& names, double period);
  /// Vehicle `k`'s sample (in time order). @throw std::runtime_error naming the spool file
  void add(std::size_t k, const OdometrySample& s);
  /// Writes the table to `path`. @throw std::runtime_error naming the file
  void write(const std::string& path);

private:
  struct Last
  {
    explicit Last(double period) : pick(period) {}
    PeriodicPick pick;
    OdometrySample sample;
    bool any = false, written = false;
  };
  std::string row(std::size_t k, const OdometrySample& s) const;

  std::vector<std::string> names_;
  SpooledTable table_;
  std::vector<Last> last_;
};

/// A gaps.csv row: `follower,leader,t,gap,lateral` (s, m, m).
std::string gapRow(const std::string& follower, const std::string& leader, const GapSample& g);
/// The header of gaps.csv.
constexpr const char* kGapsHeader = "follower,leader,t,gap,lateral";

}  // namespace results
}  // namespace avsp
