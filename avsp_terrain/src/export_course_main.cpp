// export_course: writes the embedded default course to DEM files (ROS-free; run it with
// `rosrun avsp_terrain export_course ...` or straight from the package's lib directory).
// The work is in course_export.hpp; this file only maps outcomes to messages and exit codes:
// 0 written, 1 a file could not be written, 2 bad arguments (message names flag or path).
#include <cstdio>
#include <exception>
#include <stdexcept>
#include <string>
#include <vector>

#include "avsp_terrain/course_export.hpp"
#include "avsp_terrain/dem_io.hpp"

int main(int argc, char** argv)
{
  using namespace avsp::terrain;
  ExportOptions options;
  try
  {
    options = parseExportArguments(std::vector<std::string>(argv + 1, argv + argc));
  }
  catch (const UsageError& e)
  {
    std::fprintf(stderr, "export_course: %s\n(run export_course --help for the usage)\n", e.what());
    return 2;
  }
  if (options.help)
  {
    std::fputs(exportUsage().c_str(), stdout);
    return 0;
  }
  try
  {
    const std::vector<std::string> written = exportCourse(options);
    std::printf("export_course: default course, seed %llu, %g m x %g m at %g m: wrote",
                static_cast<unsigned long long>(options.course.seed), options.course.length_x, options.course.length_y,
                options.course.cell_size);
    for (const std::string& path : written)
      std::printf(" %s", path.c_str());
    std::printf("\n");
    return 0;
  }
  catch (const UsageError& e)  // sizes makeDefaultCourse refuses
  {
    std::fprintf(stderr, "export_course: %s\n", e.what());
    return 2;
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "export_course: %s\n", e.what());
    return 1;
  }
}
