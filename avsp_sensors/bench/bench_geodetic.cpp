// Prints the cost of one ENU -> geodetic conversion (what a GPS sample costs).
#include <chrono>
#include <cstdio>

#include "avsp_sensors/geodetic.hpp"

int main()
{
  const avsp::sensors::EnuFrame frame({ 42.3, -83.2, 180.0 });
  const int n = 2000000;
  double sum = 0.0;
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < n; ++k)
  {
    const auto g = frame.toGeodetic({ 0.3 * (k % 2000), 0.2 * (k % 3000), 1.0 });
    sum += g.latitude_deg;
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("ENU -> WGS-84 geodetic: %.1f ns/conversion over %d (checksum %.6f)\n", 1e9 * s / n, n, sum);
  return 0;
}
