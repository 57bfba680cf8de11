// The implementation of csv_io.hpp: CSV input and output of the `capsflow green` command.
#include "host/base/csv_io.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string_view>
#include <system_error>

#include "host/base/atomic_file.hpp"
#include "host/base/errors.hpp"

namespace capsflow {
namespace {

std::string fmt(double v) {
  std::array<char, 64> buf{};
  auto res = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  return std::string(buf.data(), res.ptr);
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split_commas(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = s.find(',', start);
    out.push_back(trim(s.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start)));
    if (comma == std::string_view::npos) return out;
    start = comma + 1;
  }
}

// A user-supplied field shown in a message: one line, and short.
std::string quote(std::string_view s) {
  std::string q(s.substr(0, 40));
  for (char& c : q)
    if (static_cast<unsigned char>(c) < 0x20) c = '?';
  return "'" + q + (s.size() > 40 ? "...'" : "'");
}

// Reads a CSV file whose header is exactly `columns`; every data row must hold that many finite numbers.
// `store(values, line)` receives each row.
template <class Store>
void read_numeric_csv(const std::string& path, const std::vector<std::string>& columns, Store store) {
  std::string expected_header;
  for (const auto& c : columns) expected_header += (expected_header.empty() ? "" : ",") + c;

  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open: " + std::strerror(errno));

  std::string text;
  std::size_t line_no = 0;
  bool have_header = false;
  std::size_t rows = 0;
  std::vector<double> values(columns.size());
  while (std::getline(in, text)) {
    ++line_no;
    std::string_view line(text);
    if (line_no == 1 && line.substr(0, 3) == "\xEF\xBB\xBF") line.remove_prefix(3);  // UTF-8 byte order mark
    if (trim(line).empty()) continue;
    const auto fields = split_commas(line);
    const std::string where = path + ":" + std::to_string(line_no) + ": ";
    if (!have_header) {
      bool ok = fields.size() == columns.size();
      for (std::size_t i = 0; ok && i < columns.size(); ++i) ok = fields[i] == columns[i];
      if (!ok) throw InputError(where + "expected the header '" + expected_header + "', got " + quote(trim(line)));
      have_header = true;
      continue;
    }
    if (fields.size() != columns.size())
      throw InputError(where + "expected " + std::to_string(columns.size()) + " fields (" + expected_header +
                       "), got " + std::to_string(fields.size()));
    for (std::size_t i = 0; i < columns.size(); ++i) {
      const std::string field(fields[i]);
      char* end = nullptr;
      errno = 0;
      const double v = field.empty() ? 0.0 : std::strtod(field.c_str(), &end);
      // strtod also takes "inf", "nan" and out-of-range values (ERANGE, +-HUGE_VAL): all rejected here.
      const bool parsed = !field.empty() && end == field.c_str() + field.size();
      if (!parsed || !std::isfinite(v) || (errno == ERANGE && std::fabs(v) > 1.0))
        throw InputError(where + "column " + std::to_string(i + 1) + " (" + columns[i] +
                         "): expected a finite number, got " + (field.empty() ? std::string("an empty field")
                                                                                : quote(field)));
      values[i] = v;
    }
    store(values, line_no);
    ++rows;
  }
  if (in.bad()) throw InputError(path + ": read error after line " + std::to_string(line_no));
  if (!have_header) throw InputError(path + ": empty file, expected the header '" + expected_header + "'");
  if (rows == 0) throw InputError(path + ": no data rows after the header '" + expected_header + "'");
}

void validate_y(const std::vector<double>& y, const std::vector<std::size_t>& lines, double H,
                const std::string& file) {
  for (std::size_t i = 0; i < y.size(); ++i) {
    if (y[i] >= 0.0 && y[i] <= H) continue;
    const std::string line = i < lines.size() ? std::to_string(lines[i]) + ": " : std::string(" ");
    throw InputError(file + ":" + line + "row " + std::to_string(i + 1) + ": expected 0 <= y <= H = " + fmt(H) +
                     " (inside the slit), got y = " + fmt(y[i]));
  }
}

std::string directory_of(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

bool exists(const std::string& path) {
  struct stat st {};
  return ::lstat(path.c_str(), &st) == 0;
}

[[noreturn]] void throw_exists(const std::string& path) {
  throw InputError(path + ": output file already exists, not overwriting it (capsflow: pass --force)");
}

}  // namespace

PointForces read_point_forces_csv(const std::string& path) {
  PointForces p;
  read_numeric_csv(path, {"x", "y", "z", "fx", "fy", "fz"}, [&p](const std::vector<double>& v, std::size_t line) {
    p.x.push_back(v[0]);
    p.y.push_back(v[1]);
    p.z.push_back(v[2]);
    p.fx.push_back(v[3]);
    p.fy.push_back(v[4]);
    p.fz.push_back(v[5]);
    p.line.push_back(line);
  });
  return p;
}

TargetPoints read_targets_csv(const std::string& path) {
  TargetPoints t;
  read_numeric_csv(path, {"x", "y", "z"}, [&t](const std::vector<double>& v, std::size_t line) {
    t.x.push_back(v[0]);
    t.y.push_back(v[1]);
    t.z.push_back(v[2]);
    t.line.push_back(line);
  });
  return t;
}

void validate_in_slit(const PointForces& points, double H, const std::string& file) {
  validate_y(points.y, points.line, H, file);
}

void validate_in_slit(const TargetPoints& points, double H, const std::string& file) {
  validate_y(points.y, points.line, H, file);
}

void check_output_path(const std::string& path, bool overwrite) {
  if (path.empty()) throw InputError("output file name is empty");
  check_output_kind(path);
  if (!overwrite && exists(path)) throw_exists(path);
  const std::string dir = directory_of(path);
  struct stat st {};
  if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
    throw InputError(path + ": the output directory '" + dir + "' does not exist");
  if (::access(dir.c_str(), W_OK) != 0)
    throw InputError(path + ": the output directory '" + dir + "' is not writable");
}

void write_velocities_csv(const std::string& path, const TargetPoints& targets, const double* ux,
                          const double* uy, const double* uz, bool overwrite) {
  check_output_path(path, overwrite);

  // Temporary file next to the final one (same file system, so rename/link is atomic).
  const std::string dir = directory_of(path);
  const std::string base = path.substr(path.rfind('/') == std::string::npos ? 0 : path.rfind('/') + 1);
  std::string tmp = dir + "/." + base + ".tmp.XXXXXX";
  const int fd = ::mkstemp(tmp.data());
  if (fd < 0) throw InputError(path + ": cannot create a temporary file in '" + dir + "': " + std::strerror(errno));
  struct Cleanup {  // removes the temporary file on every path that does not rename it
    std::string name;
    bool armed = true;
    ~Cleanup() {
      if (armed) ::unlink(name.c_str());
    }
  } cleanup{tmp};
  std::FILE* f = ::fdopen(fd, "w");
  if (!f) {
    ::close(fd);
    throw InputError(path + ": cannot open the temporary file '" + tmp + "': " + std::strerror(errno));
  }
  // mkstemp creates mode 0600; give the result the usual permissions (0666 minus the umask).
  const mode_t mask = ::umask(0);
  ::umask(mask);
  ::fchmod(fd, 0666 & ~mask);

  bool ok = std::fputs("x,y,z,ux,uy,uz\n", f) >= 0;
  for (std::size_t i = 0; ok && i < targets.size(); ++i)
    ok = std::fprintf(f, "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", targets.x[i], targets.y[i], targets.z[i], ux[i],
                      uy[i], uz[i]) > 0;
  ok = ok && std::fflush(f) == 0 && ::fsync(fd) == 0;
  const int write_errno = errno;
  const bool closed = std::fclose(f) == 0;
  // A full disk or an I/O error is the system's failure (exit 1), not a bad input.
  if (!ok || !closed)
    throw std::system_error(write_errno ? write_errno : EIO, std::generic_category(),
                            path + ": cannot write the temporary file '" + tmp + "'");

  if (overwrite) {
    if (::rename(tmp.c_str(), path.c_str()) != 0)
      throw InputError(path + ": cannot rename '" + tmp + "' to it: " + std::strerror(errno));
    cleanup.armed = false;
  } else {
    // link() fails with EEXIST if the name appeared meanwhile: never replaces a file that was not ours.
    if (::link(tmp.c_str(), path.c_str()) != 0) {
      if (errno == EEXIST) throw_exists(path);
      // File systems without hard links: check-then-rename (a narrow race, acceptable there).
      if (exists(path)) throw_exists(path);
      if (::rename(tmp.c_str(), path.c_str()) != 0)
        throw InputError(path + ": cannot rename '" + tmp + "' to it: " + std::strerror(errno));
      cleanup.armed = false;
    }
  }
  // Make the new directory entry durable too.
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

}  // namespace capsflow
