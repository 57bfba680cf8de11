#pragma once
// CSV input and output of the `capsflow green` command (formats in docs/usage.md).
//
//   sources  header  x,y,z,fx,fy,fz   one point force per row
//   targets  header  x,y,z            one target point per row
//   output   header  x,y,z,ux,uy,uz   one row per target, in input order, every value printed with %.17g
//
// Readers return structure-of-arrays, ready for the flat kernels. Every reading error is an InputError whose
// one-line message names the file and the line ("sources.csv:7: ..."). Blank lines are skipped; a trailing
// '\r' (files from Windows) is ignored.
//
// Writing is atomic: the rows go to a temporary file in the output's directory, which is flushed to disk and
// then renamed over (or linked to) the final name. A crash or an error leaves either the old file or no file,
// never a partial one, and an existing file is only replaced when the caller asks for it.
#include <cstddef>
#include <string>
#include <vector>

namespace capsflow {

// Point forces f_m at positions x_m.
struct PointForces {
  std::vector<double> x, y, z;
  std::vector<double> fx, fy, fz;
  std::vector<std::size_t> line;  // line of the file each row came from (for messages)
  std::size_t size() const { return x.size(); }
};

// Points where the velocity is wanted.
struct TargetPoints {
  std::vector<double> x, y, z;
  std::vector<std::size_t> line;  // line of the file each row came from (for messages)
  std::size_t size() const { return x.size(); }
};

PointForces read_point_forces_csv(const std::string& path);
TargetPoints read_targets_csv(const std::string& path);

// Throws InputError for the first point with y outside [0, H] (exact bounds: points on a wall are allowed),
// naming `file`, the line and the row.
void validate_in_slit(const PointForces& points, double H, const std::string& file);
void validate_in_slit(const TargetPoints& points, double H, const std::string& file);

// Fails early (InputError), before any expensive work, when write_velocities_csv(path, ..., overwrite) is bound
// to fail: the file exists and overwrite is false, or its directory does not exist or is not writable.
void check_output_path(const std::string& path, bool overwrite);

// Writes x,y,z,ux,uy,uz for every target atomically (see above). ux, uy, uz hold targets.size() values each.
// Without overwrite an existing file is an InputError and stays untouched.
void write_velocities_csv(const std::string& path, const TargetPoints& targets, const double* ux,
                          const double* uy, const double* uz, bool overwrite);

}  // namespace capsflow
