#pragma once
/**
 * @file liggghts.hpp
 * @brief The few functions of LIGGGHTS' library interface AVSP uses, and an owner for one
 *        instance. Private to avsp_dynamics_dem.
 *
 * Declared here rather than by including <liggghts/library.h>: that header includes <mpi.h>
 * for lammps_open()'s communicator, which AVSP never uses (serial runs, lammps_open_no_mpi),
 * and would make every build need MPI's development headers. These are the same C symbols.
 */
#include <cstdarg>
#include <string>

extern "C"
{
  void lammps_open_no_mpi(int, char**, void**);
  void lammps_close(void*);
  char* lammps_command(void*, const char*);
  void lammps_free(void*);
  void* lammps_extract_global(void*, const char*);
  void* lammps_extract_atom(void*, const char*);
  void* lammps_extract_fix(void*, const char*, int, int, int, int);
  int lammps_get_natoms(void*);
}

namespace avsp
{
namespace dynamics
{
namespace dem
{
/// One LIGGGHTS instance: its screen output discarded, its log in `log_path`.
class Liggghts
{
public:
  explicit Liggghts(const std::string& log_path);
  ~Liggghts();
  Liggghts(const Liggghts&) = delete;
  Liggghts& operator=(const Liggghts&) = delete;

  /// Runs one input command (printf-style).
  void command(const char* format, ...) __attribute__((format(printf, 2, 3)));

  /// Element `index` of the global vector of fix `id`.
  double fixVector(const std::string& id, int index) const;

  int localAtoms() const;
  double** positions() const;
  double** velocities() const;
  double** angularVelocities() const;
  double* radii() const;
  double* masses() const;
  int* types() const;

  void* handle() const { return handle_; }

private:
  void* handle_ = nullptr;
};

}  // namespace dem
}  // namespace dynamics
}  // namespace avsp
