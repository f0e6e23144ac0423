#include "avsp_sensors/geomagnetic_model.hpp"

#include <cmath>
#include <sstream>
#include <utility>

#include <GeographicLib/MagneticModel.hpp>
#include <GeographicLib/Utility.hpp>

namespace avsp
{
namespace sensors
{
namespace
{
std::string fixed(double value, int digits)
{
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(digits);
  out << value;
  return out.str();
}

/// GeographicLib names a model by folder and stem: ".../wmm2025.wmm" -> (".../", "wmm2025").
std::shared_ptr<const GeographicLib::MagneticModel> load(const std::string& file)
{
  const std::string suffix = ".wmm";
  if (file.size() <= suffix.size() || file.compare(file.size() - suffix.size(), suffix.size(), suffix) != 0)
    throw GeomagneticModelError("magnetic model file " + file + ": the name must end in .wmm (GeographicLib's format)");
  const std::size_t slash = file.rfind('/');
  const std::string dir = slash == std::string::npos ? "." : file.substr(0, slash);
  const std::size_t start = slash == std::string::npos ? 0 : slash + 1;
  const std::string stem = file.substr(start, file.size() - suffix.size() - start);
  try
  {
    return std::make_shared<const GeographicLib::MagneticModel>(stem, dir);
  }
  catch (const std::exception& e)  // GeographicErr, or std::bad_alloc for an absurd degree
  {
    throw GeomagneticModelError("magnetic model file " + file + ": " + e.what());
  }
}
}  // namespace

double decimalYear(const std::string& date)
{
  // GeographicLib reads "now" as today's date: refused, a run must not depend on when it runs.
  if (date.empty() || date == "now")
    throw GeomagneticModelError("date '" + date + "': expected YYYY-MM-DD or a decimal year such as 2027.5");
  double year = 0.0;
  try
  {
    year = GeographicLib::Utility::fractionalyear<double>(date);
  }
  catch (const std::exception& e)
  {
    throw GeomagneticModelError("date '" + date + "': expected YYYY-MM-DD or a decimal year such as 2027.5 (" +
                                e.what() + ")");
  }
  if (!std::isfinite(year))
    throw GeomagneticModelError("date '" + date + "' is not a finite year");
  return year;
}

GeomagneticModel::GeomagneticModel(const std::string& wmm_file) : file_(wmm_file), model_(load(wmm_file))
{
  if (!std::isfinite(model_->MinTime()) || !std::isfinite(model_->MaxTime()) || !std::isfinite(model_->MinHeight()) ||
      !std::isfinite(model_->MaxHeight()))
    throw GeomagneticModelError("magnetic model file " + file_ +
                                ": MinTime, MaxTime, MinHeight and MaxHeight must be given (the model's validity)");
}

std::string GeomagneticModel::name() const
{
  return model_->MagneticModelName();
}

std::string GeomagneticModel::description() const
{
  return model_->Description();
}

double GeomagneticModel::minYear() const
{
  return model_->MinTime();
}

double GeomagneticModel::maxYear() const
{
  return model_->MaxTime();
}

double GeomagneticModel::minHeight() const
{
  return model_->MinHeight();
}

double GeomagneticModel::maxHeight() const
{
  return model_->MaxHeight();
}

void GeomagneticModel::checkYear(double year, const std::string& what) const
{
  // GeographicLib extrapolates outside the validity without a word: the secular variation is a
  // five-year linear fit, and beyond it the model is not the model.
  if (!(year >= minYear() && year <= maxYear()))
    throw GeomagneticModelError(name() + " (" + file_ + ") is valid for decimal years " + fixed(minYear(), 1) + " to " +
                                fixed(maxYear(), 1) + ": " + what + " is " + fixed(year, 3));
}

Eigen::Vector3d GeomagneticModel::fieldEnu(const Geodetic& p, double year) const
{
  checkYear(year, "the year");
  if (!std::isfinite(p.latitude_deg) || !std::isfinite(p.longitude_deg) || !std::isfinite(p.altitude) ||
      std::abs(p.latitude_deg) > 90.0)
    throw GeomagneticModelError(name() + ": point (lat " + fixed(p.latitude_deg, 6) + " deg, lon " +
                                fixed(p.longitude_deg, 6) + " deg, alt " + fixed(p.altitude, 1) +
                                " m) is not a valid position");
  if (!(p.altitude >= minHeight() && p.altitude <= maxHeight()))
    throw GeomagneticModelError(name() + " (" + file_ + ") is valid from " + fixed(minHeight(), 0) + " to " +
                                fixed(maxHeight(), 0) + " m above the ellipsoid: the point is at " +
                                fixed(p.altitude, 1) + " m");
  double east = 0.0, north = 0.0, up = 0.0;
  (*model_)(year, p.latitude_deg, p.longitude_deg, p.altitude, east, north, up);
  return Eigen::Vector3d(east, north, up) * 1e-9;  // nT -> T
}

MapMagneticField::MapMagneticField(GeomagneticModel model, const EnuFrame& map, double year)
  : model_(std::move(model)), map_(map), year_(year)
{
  model_.checkYear(year, "the date");
  at(Eigen::Vector3d::Zero());  // the origin's height within the model's, or the reason
}

Eigen::Vector3d MapMagneticField::at(const Eigen::Vector3d& map_position) const
{
  Eigen::Matrix3d local_to_map;
  const Geodetic g = map_.toGeodetic(map_position, local_to_map);
  return local_to_map * model_.fieldEnu(g, year_);
}

}  // namespace sensors
}  // namespace avsp
