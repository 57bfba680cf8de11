// The implementation of render_command.hpp: `capsflow render`, the 3D pictures and movie of a run drawn by ParaView.
#include "host/cli/render_command.hpp"

#include <CLI/CLI.hpp>
#include <signal.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <system_error>

#include <nlohmann/json.hpp>
#include <toml++/toml.h>

#include "host/base/atomic_file.hpp"
#include "host/base/errors.hpp"
#include "host/base/fault_injection.hpp"
#include "host/base/h5_file.hpp"
#include "host/cli/figures_command.hpp"
#include "host/cli/subprocess.hpp"
#include "host/run/run_layout.hpp"
#include "host/run/run_marker.hpp"
#include "host/run/stop_signal.hpp"

namespace capsflow {
namespace {

namespace fs = std::filesystem;

constexpr const char* kScript = "capsflow_render.py";
constexpr const char* kLockName = "render.lock";  // DIR's lock while a render draws into it (run_marker.hpp)
constexpr const char* kPackages = "on Debian: apt-get install paraview python3-paraview xvfb xauth";
const std::vector<std::string> kColors = {"species",  "tension_max", "tension_min", "energy_density",
                                          "velocity", "traction_jump"};

bool is_vector_field(const std::string& c) { return c == "velocity" || c == "traction_jump"; }

struct PixelSize {
  int width = 0, height = 0;
};

// "WxH", each an integer in [64, 8192].
std::optional<PixelSize> parse_size(const std::string& v) {
  const std::size_t x = v.find('x');
  if (x == std::string::npos || x == 0 || x + 1 >= v.size()) return std::nullopt;
  PixelSize s;
  for (auto [text, out] : {std::pair{v.substr(0, x), &s.width}, std::pair{v.substr(x + 1), &s.height}}) {
    if (text.size() > 5 || !std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; }))
      return std::nullopt;
    *out = std::stoi(text);
    if (*out < 64 || *out > 8192) return std::nullopt;
  }
  return s;
}

std::optional<double> parse_finite(const std::string& v) {
  char* end = nullptr;
  const double x = std::strtod(v.c_str(), &end);
  if (v.empty() || !end || *end != '\0' || !std::isfinite(x)) return std::nullopt;
  return x;
}

// "LO:HI", both finite, LO < HI.
std::optional<std::pair<double, double>> parse_range(const std::string& v) {
  const std::size_t colon = v.find(':');
  if (colon == std::string::npos) return std::nullopt;
  const auto lo = parse_finite(v.substr(0, colon)), hi = parse_finite(v.substr(colon + 1));
  if (!lo || !hi || !(*lo < *hi)) return std::nullopt;
  return std::pair{*lo, *hi};
}

std::string number_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

// What the run file says about the picture: frames, the field's units, species names, the box.
struct RunFacts {
  std::vector<double> frame_times;
  std::size_t nodes = 0, capsules = 0;
  std::string units;
  std::vector<std::string> species;
  std::vector<double> species_ca;     // per species index, from the stored [[species]] (NaN when not given)
  std::vector<std::size_t> species_count;  // capsules of each species
  double Lx = 0, H = 0, Lz = 0;
};

// One palette for the species in every picture of the project: stiff (the smaller Ca) tab:blue, floppy (the larger)
// tab:red, as `capsflow figures` draws them; a further species (or a run whose species share one Ca) takes the next
// tab10 colours in species order.
const std::vector<std::array<double, 3>> kTab10 = {
    {0.122, 0.467, 0.706}, {0.839, 0.153, 0.157}, {0.173, 0.627, 0.173}, {0.580, 0.404, 0.741},
    {1.000, 0.498, 0.055}, {0.549, 0.337, 0.294}, {0.890, 0.467, 0.761}, {0.498, 0.498, 0.498},
    {0.737, 0.741, 0.133}, {0.090, 0.745, 0.812}};

std::vector<std::array<double, 3>> species_colours(const RunFacts& r) {
  const std::size_t n = r.species.size();
  std::vector<int> pick(n, -1);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (double c : r.species_ca)
    if (std::isfinite(c)) lo = std::min(lo, c), hi = std::max(hi, c);
  if (lo < hi)
    for (std::size_t s = 0; s < n && s < r.species_ca.size(); ++s) {
      if (r.species_ca[s] == lo) pick[s] = 0;       // stiff: tab:blue
      else if (r.species_ca[s] == hi) pick[s] = 1;  // floppy: tab:red
    }
  const bool by_ca = std::any_of(pick.begin(), pick.end(), [](int p) { return p >= 0; });
  int next = by_ca ? 2 : 0;
  std::vector<std::array<double, 3>> out;
  for (std::size_t s = 0; s < n; ++s) {
    const int k = pick[s] >= 0 ? pick[s] : next++;
    out.push_back(kTab10[static_cast<std::size_t>(k) % kTab10.size()]);
  }
  return out;
}

// The picture's title: the file, X_f (the floppy number fraction, with two species of different Ca) and each
// species' Ca and count; the strain is added by the renderer, frame by frame.
std::string picture_title(const std::string& run, const RunFacts& r) {
  std::string t = fs::path(run).filename().string();
  const auto g = [](double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%g", v);
    return std::string(b);
  };
  std::size_t total = 0;
  for (std::size_t c : r.species_count) total += c;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (double c : r.species_ca)
    if (std::isfinite(c)) lo = std::min(lo, c), hi = std::max(hi, c);
  if (r.species.size() == 2 && lo < hi && total > 0) {
    std::size_t floppy = 0;
    for (std::size_t s = 0; s < 2; ++s)
      if (r.species_ca[s] == hi) floppy += r.species_count[s];
    t += "   X_f " + g(static_cast<double>(floppy) / static_cast<double>(total));
  }
  for (std::size_t s = 0; s < r.species.size(); ++s) {
    t += s == 0 ? "   " : ", ";
    t += std::to_string(s < r.species_count.size() ? r.species_count[s] : 0) + " " + r.species[s];
    if (s < r.species_ca.size() && std::isfinite(r.species_ca[s])) t += " (Ca " + g(r.species_ca[s]) + ")";
  }
  return t;
}

RunFacts read_run_facts(const RenderOptions& o) {
  check_run_output(o.run);
  const H5File f = H5File::open(o.run, H5Access::ReadShared);  // a live run's file too
  refuse_run_store_file(f, o.run);  // a store's part draws a stretch of the run as if it were all of it
  RunFacts r;
  if (!f.exists(layout::kFrameTime) || !f.exists(layout::kFramePositions))
    throw InputError(o.run + ": no frames (/frames/time, /frames/positions): not a capsflow run output");
  // A live run's last frame may be half written: the frames both datasets hold.
  const std::size_t n = std::min(f.extent(layout::kFrameTime), f.extent(layout::kFramePositions));
  if (n == 0) throw InputError(o.run + ": no frames yet (a run writes one every [output] frames_every)");
  r.frame_times = f.read_records<double>(layout::kFrameTime, 0, n).data;
  r.nodes = f.dims(layout::kFramePositions).at(1);
  r.capsules = f.extent(layout::kCapsuleSpecies);
  const std::string names =
      f.has_attribute(layout::kCapsuleSpecies, "names") ? f.attribute<std::string>(layout::kCapsuleSpecies, "names") : "";
  std::stringstream ss(names);
  for (std::string s; std::getline(ss, s, ',');) r.species.push_back(s);
  const std::vector<std::int32_t> slot = f.read<std::int32_t>(layout::kCapsuleSpecies).data;
  for (std::int32_t s : slot)
    while (static_cast<std::int32_t>(r.species.size()) <= s) r.species.push_back("species " + std::to_string(r.species.size()));
  r.species_count.assign(r.species.size(), 0);
  for (std::int32_t s : slot)
    if (s >= 0) ++r.species_count[static_cast<std::size_t>(s)];

  if (o.color != "species") {
    const std::string path = "/frames/" + o.color;
    if (!f.exists(path)) {
      const std::int64_t version = f.has_attribute("/", layout::kAttrFormat) ? f.attribute<std::int64_t>("/", layout::kAttrFormat) : 1;
      throw InputError("--color " + o.color + ": " + o.run + " has no " + path + " (output format " +
                       std::to_string(version) + "; the membrane fields came with format 5): colour by species or velocity");
    }
    r.units = f.has_attribute(path, layout::kAttrDatasetUnits) ? f.attribute<std::string>(path, layout::kAttrDatasetUnits)
                                                               : (o.color == "velocity" ? "gammadot a" : "");
  }
  // The box from the stored configuration (toml++ directly: an older format's configuration need not pass today's
  // checks to give its domain).
  try {
    const toml::table cfg = toml::parse(f.read_string(layout::kConfig));
    r.H = cfg["domain"]["H"].value<double>().value_or(0.0);
    r.Lx = cfg["domain"]["Lx"].value<double>().value_or(0.0);
    r.Lz = cfg["domain"]["Lz"].value<double>().value_or(0.0);
    r.species_ca.assign(r.species.size(), std::numeric_limits<double>::quiet_NaN());
    if (const toml::array* sp = cfg["species"].as_array())
      for (std::size_t s = 0; s < sp->size() && s < r.species_ca.size(); ++s)
        if (const toml::table* t = sp->get(s)->as_table())
          r.species_ca[s] = (*t)["ca"].value<double>().value_or(std::numeric_limits<double>::quiet_NaN());
  } catch (const toml::parse_error& e) {
    throw InputError(o.run + ": " + layout::kConfig + " is not TOML (" + std::string(e.description()) + ")");
  }
  if (!(r.H > 0 && r.Lx > 0 && r.Lz > 0))
    throw InputError(o.run + ": " + layout::kConfig + " gives no box ([domain] H, Lx, Lz)");
  return r;
}

// min .. max of the field (vectors: their magnitude) over the frames drawn, non-finite values left out.
std::pair<double, double> field_range(const RenderOptions& o, const std::vector<std::size_t>& frames) {
  const H5File f = H5File::open(o.run, H5Access::ReadShared);
  const std::string path = "/frames/" + o.color;
  const bool vec = is_vector_field(o.color);
  double lo = INFINITY, hi = -INFINITY;
  for (std::size_t fr : frames) {
    const std::vector<double> v = f.read_records<double>(path, fr, 1).data;
    for (std::size_t i = 0; i < v.size(); i += vec ? 3 : 1) {
      const double x = vec ? std::sqrt(v[i] * v[i] + v[i + 1] * v[i + 1] + v[i + 2] * v[i + 2]) : v[i];
      if (!std::isfinite(x)) continue;
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
  }
  if (!(lo <= hi)) return {0.0, 1.0};  // nothing finite: any range draws the NaN colour
  // A uniform field (a fresh, evenly inflated capsule) still needs a range to map.
  if (hi - lo <= 1e-9 * std::max(1.0, std::abs(hi))) {
    const double pad = std::max(1e-9, 0.01 * std::abs(hi));
    lo -= pad;
    hi += pad;
  }
  return {lo, hi};
}

// A bar on a terminal (redrawn in place), a line per quarter otherwise (a log file stays short).
class ProgressBar {
 public:
  ProgressBar(std::ostream& log, bool on, std::string what, std::size_t total)
      : log_(log), on_(on), tty_(::isatty(STDERR_FILENO) == 1), what_(std::move(what)), total_(total),
        t0_(std::chrono::steady_clock::now()) {}
  void update(std::size_t done) {
    if (!on_ || total_ == 0) return;
    const double frac = static_cast<double>(done) / static_cast<double>(total_);
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
    char eta[48] = "";
    if (done > 0 && done < total_)
      std::snprintf(eta, sizeof eta, "  %.0f s left", elapsed / frac - elapsed);
    else if (done == total_)
      std::snprintf(eta, sizeof eta, "  %.1f s", elapsed);
    if (tty_) {
      const int width = 30, filled = static_cast<int>(frac * width);
      log_ << "\r  " << what_ << " [" << std::string(static_cast<std::size_t>(filled), '#')
           << std::string(static_cast<std::size_t>(width - filled), '.') << "] " << done << "/" << total_ << eta
           << "   " << (done == total_ ? "\n" : "") << std::flush;
    } else if (static_cast<int>(frac * 4) > quarter_ || done == total_) {
      quarter_ = static_cast<int>(frac * 4);
      if (done == total_ && reported_end_) return;
      reported_end_ = done == total_;
      log_ << "  " << what_ << " " << done << "/" << total_ << eta << "\n" << std::flush;
    }
  }

 private:
  std::ostream& log_;
  bool on_, tty_;
  std::string what_;
  std::size_t total_;
  std::chrono::steady_clock::time_point t0_;
  int quarter_ = 0;
  bool reported_end_ = false;
};

std::string strip_ansi(const std::string& s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '\x1b' && i + 1 < s.size() && s[i + 1] == '[') {
      i += 2;
      while (i < s.size() && !(s[i] >= '@' && s[i] <= '~')) ++i;
      continue;
    }
    out += s[i];
  }
  return out;
}

// The line of a helper's log that says what went wrong: the script's own ("capsflow-render: ..."), else the last
// line that names an error, else the last line.
std::string failure_line(const fs::path& log) {
  std::ifstream in(log);
  std::string line, own, error, last;
  while (std::getline(in, line)) {
    line = strip_ansi(line);
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    if (line.empty()) continue;
    if (line.rfind("capsflow-render: ", 0) == 0) own = line.substr(17);
    if (line.find("Error") != std::string::npos || line.find("ERR|") != std::string::npos ||
        line.find("error") != std::string::npos)
      error = line;
    last = line;
  }
  std::string out = !own.empty() ? own : !error.empty() ? error : last;
  if (out.size() > 400) out = out.substr(0, 400) + " ...";
  return out.empty() ? std::string("no message") : out;
}

bool pid_alive(long pid) { return pid > 0 && (::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM); }

// Temporary directories of earlier renders into `dir` whose process is gone (killed, interrupted).
void remove_stale_render_dirs(const fs::path& dir) {
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind(".render.tmp.", 0) != 0) continue;
    const long pid = std::strtol(name.c_str() + 12, nullptr, 10);
    if (!pid_alive(pid)) fs::remove_all(e.path(), ec);
  }
}

// Removes the temporary directory on every way out.
// The folders of --out that this render creates, removed again (when empty) unless it succeeds: a render that fails
// or is refused after creating them leaves the working directory as it was.
class CreatedDirs {
 public:
  explicit CreatedDirs(const fs::path& dir) {
    std::error_code ec;
    for (fs::path p = dir; !p.empty() && !fs::exists(fs::symlink_status(p, ec)); p = p.parent_path())
      made_.push_back(p);
  }
  ~CreatedDirs() {
    std::error_code ec;
    for (const fs::path& p : made_) fs::remove(p, ec);  // deepest first; a folder with something in it stays
  }
  CreatedDirs(const CreatedDirs&) = delete;
  CreatedDirs& operator=(const CreatedDirs&) = delete;
  void keep() { made_.clear(); }

 private:
  std::vector<fs::path> made_;
};

struct TempDirGuard {
  fs::path path;
  ~TempDirGuard() {
    std::error_code ec;
    if (!path.empty()) fs::remove_all(path, ec);
  }
};

std::string padded(std::size_t v, std::size_t width) {
  std::string s = std::to_string(v);
  return std::string(width > s.size() ? width - s.size() : 0, '0') + s;
}

int fail(const std::string& message) {
  std::cerr << "capsflow: error: " << message << "\n";
  return 1;
}

// A signal reached us while `program` ran: its process group has been ended (subprocess.hpp); the temporary directory
// goes with its guard on the way out. The shell's status for a death by that signal, 128 + signal.
int stopped(int sig, const std::string& program, const fs::path& dir) {
  std::cerr << "capsflow: error: render stopped by " << signal_name(sig) << ": " << program
            << " and what it started are ended; nothing written into " << dir.string() << "\n";
  return 128 + sig;
}

bool is_nonempty_file(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec) && fs::file_size(p, ec) > 0 && !ec;
}

// "the disk is full (N KiB free)" when the disk holding `dir` has less than 1 MiB left for us; empty otherwise.
std::string disk_full(const fs::path& dir) {
  struct statvfs st {};
  if (::statvfs(dir.c_str(), &st) != 0) return "";
  const unsigned long long free = static_cast<unsigned long long>(st.f_bavail) * st.f_frsize;
  if (free >= (1ull << 20)) return "";
  return "the disk is full (" + std::to_string(free / 1024) + " KiB free)";
}

// A file-system failure after the checks in one line: the file and the system's reason, and on a full disk (or
// quota) which folder's disk and what to change.
std::string file_failure(const std::system_error& e, const fs::path& dir) {
  std::string line;
  if (const auto* fe = dynamic_cast<const fs::filesystem_error*>(&e))
    line = fe->path1().string() + ": " + fe->code().message();  // not what(): "filesystem error: ... [a] [b]"
  else
    line = e.what();  // "cannot write 'FILE': reason" (atomic_file.hpp, the folder's lock, the job)
  if (e.code() == std::errc::no_space_on_device || e.code() == std::error_code(EDQUOT, std::generic_category()))
    line += " (the disk holding " + dir.string() + " is full: free space there or choose another --out); the " +
            "folder is as it was";
  return line;
}

// The outputs going into place, all or none: before an output is replaced (--force) its former self is hard-linked
// into the temporary directory; undo() removes the outputs this render created and links the replaced ones back
// (rename: atomic). Where the file system has no hard links, a replaced output stays new (complete) after a failure.
class Placement {
 public:
  explicit Placement(fs::path tmp) : tmp_(std::move(tmp)) {}
  void keep(const fs::path& out) {
    std::error_code ec;
    Entry e{out, {}, fs::exists(fs::symlink_status(out, ec))};
    if (e.existed) {
      e.former = tmp_ / ("former." + std::to_string(entries_.size()) + "." + out.filename().string());
      if (::link(out.c_str(), e.former.c_str()) != 0) e.former.clear();
    }
    entries_.push_back(std::move(e));
  }
  void undo() {
    std::error_code ec;
    for (const Entry& e : entries_) {
      if (!e.former.empty()) fs::rename(e.former, e.out, ec);
      else if (!e.existed) fs::remove(e.out, ec);
    }
  }

 private:
  struct Entry {
    fs::path out, former;
    bool existed = false;
  };
  fs::path tmp_;
  std::vector<Entry> entries_;
};

// A file pvbatch or ffmpeg wrote in the temporary directory (on the output's file system) moved onto `to`: synced,
// renamed, the directory synced, by replace_file_atomically; `to` stays as it was when a step before the rename fails.
void move_into_place(const fs::path& from, const fs::path& to) {
  replace_file_atomically(to, [&](const fs::path& tmp) { fs::rename(from, tmp); });
}

}  // namespace

CLI::App* add_render(CLI::App& app, RenderOptions& o) {
  CLI::App* r = app.add_subcommand(
      "render", "3D pictures of a run's capsules (ParaView's pvbatch): chosen frames as PNG, --movie an MP4, and a "
                "ParaView state of the same view");
  r->add_option("RUN.h5", o.run, "A run output (its ParaView index RUN.xdmf beside it)")->required()->type_name("RUN.h5");
  r->add_option("--out", o.out, "Directory for the pictures (created)")
      ->required()
      ->type_name("DIR")
      ->check(CLI::Validator([](std::string& v) { return v.empty() ? std::string("expected a directory, got an empty string") : ""; },
                             "", "non-empty"));
  r->add_option("--frame", o.frames, "Frame to draw (0 the first, -1 the last; repeatable); default: the last")
      ->type_name("I")
      ->check(CLI::Range(-1000000000L, 1000000000L).description(""));
  r->add_option("--time", o.times, "Draw the frame nearest this strain (repeatable)")
      ->type_name("T")
      ->check(CLI::Validator(
          [](std::string& v) {
            const auto x = parse_finite(v);
            return x && *x >= 0 ? std::string() : "expected a finite strain >= 0, got '" + v + "'";
          },
          "", "strain"));
  r->add_option("--color", o.color,
                "Colour the capsules by species or by a node field: tension_max, tension_min, energy_density, "
                "velocity, traction_jump (vectors by magnitude)")
      ->check(CLI::IsMember(kColors))
      ->capture_default_str();
  r->add_option("--range", o.range, "Colour range of a field, LO:HI (default: its min..max over the frames drawn)")
      ->type_name("LO:HI")
      ->check(CLI::Validator(
          [](std::string& v) {
            return parse_range(v) ? std::string() : "expected LO:HI with finite LO < HI, got '" + v + "'";
          },
          "", "range"));
  r->add_option("--size", o.size, "Picture size in pixels, WxH (64-8192 each; even for --movie)")
      ->type_name("WxH")
      ->check(CLI::Validator(
          [](std::string& v) {
            return parse_size(v) ? std::string() : "expected WxH, integers 64-8192, got '" + v + "'";
          },
          "", "size"))
      ->capture_default_str();
  r->add_option("--view", o.view,
                "side: orthographic, looking along z (the flow x to the right, the walls top and bottom); top: "
                "orthographic, looking down y onto the x-z plane; oblique: a perspective from +z, above and downstream")
      ->check(CLI::IsMember({"side", "top", "oblique"}))
      ->capture_default_str();
  r->add_flag("--movie", o.movie, "Also an MP4 of the whole run (ffmpeg, H.264)");
  r->add_option("--fps", o.fps, "Movie frames per second")->check(CLI::Range(1, 120))->capture_default_str();
  r->add_option("--stride", o.stride, "Movie: every N-th frame")->check(CLI::Range(1, 1000000))->capture_default_str();
  r->add_flag("--force", o.force, "Replace existing pictures, movie and state");
  r->add_flag("-q,--quiet", o.quiet, "No progress bar, no summary");
  r->footer("Needs ParaView's pvbatch (Debian: paraview python3-paraview), without a display xvfb-run (xvfb xauth), "
            "for --movie ffmpeg. Exit status: 0 done, 2 input error (nothing written), 1 pvbatch or ffmpeg failed, "
            "128 + N stopped by signal N (pvbatch and what it started ended with it).");
  return r;
}

int run_render(const RenderOptions& o, std::ostream& log) {
  // --- the input and the options, before anything is written ------------------------------------------------------
  std::error_code ec;
  if (!fs::is_regular_file(o.run, ec)) throw InputError(o.run + ": no such file (expected a run's OUT.h5)");
  const RunFacts facts = read_run_facts(o);
  const fs::path xdmf = run_paths(o.run).xdmf;
  if (!fs::is_regular_file(xdmf, ec))
    throw InputError(o.run + ": its ParaView index " + xdmf.string() + " is missing (capsflow run writes it beside the "
                     "run file; keep the two together)");
  const std::size_t nf = facts.frame_times.size();
  std::vector<std::size_t> chosen;
  for (long i : o.frames) {
    const long n = static_cast<long>(nf);
    if (i < -n || i >= n)
      throw InputError("--frame " + std::to_string(i) + ": " + o.run + " has " + std::to_string(nf) + " frames (0.." +
                       std::to_string(nf - 1) + ", or -" + std::to_string(nf) + "..-1 counted from the end)");
    chosen.push_back(static_cast<std::size_t>(i < 0 ? n + i : i));
  }
  for (double t : o.times) {
    std::size_t best = 0;
    for (std::size_t k = 1; k < nf; ++k)
      if (std::abs(facts.frame_times[k] - t) < std::abs(facts.frame_times[best] - t)) best = k;
    chosen.push_back(best);
  }
  if (chosen.empty()) chosen.push_back(nf - 1);
  std::sort(chosen.begin(), chosen.end());
  chosen.erase(std::unique(chosen.begin(), chosen.end()), chosen.end());
  std::vector<std::size_t> movie;
  if (o.movie)
    for (std::size_t k = 0; k < nf; k += static_cast<std::size_t>(o.stride)) movie.push_back(k);
  const PixelSize px = *parse_size(o.size);
  if (o.movie && (px.width % 2 || px.height % 2))
    throw InputError("--size " + o.size + ": a movie needs an even width and height (H.264, 4:2:0)");
  std::optional<std::pair<double, double>> range;
  if (!o.range.empty()) {
    if (o.color == "species") throw InputError("--range " + o.range + ": only with a field (--color tension_max, ...)");
    range = parse_range(o.range);
  }

  const fs::path dir = o.out;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) throw InputError("--out " + o.out + ": exists and is not a directory");
  const std::string tag = fs::path(o.run).stem().string() + "_" + o.color;
  std::size_t digits = std::to_string(nf - 1).size();
  digits = std::max<std::size_t>(digits, 4);
  std::vector<std::pair<std::size_t, fs::path>> pictures;  // frame -> its PNG
  for (std::size_t k : chosen) pictures.emplace_back(k, dir / (tag + "_f" + padded(k, digits) + ".png"));
  const fs::path mp4 = dir / (tag + ".mp4"), state = dir / (tag + ".pvsm");
  std::vector<fs::path> outputs;
  for (const auto& p : pictures) outputs.push_back(p.second);
  if (o.movie) outputs.push_back(mp4);
  outputs.push_back(state);
  const auto check_outputs = [&] {
    for (const fs::path& p : outputs) {
      check_output_kind(p);  // never a link or a device, --force or not
      if (fs::is_directory(fs::symlink_status(p, ec)))
        throw InputError(p.string() + ": is a directory; a render writes its pictures, movie and state as files and "
                         "--force does not replace a directory: remove it or choose another --out");
      if (!o.force && fs::exists(fs::symlink_status(p, ec)))
        throw InputError(p.string() + ": exists; it is replaced only on request (capsflow render --force)");
    }
  };
  check_outputs();

  // --- the programs -------------------------------------------------------------------------------------------------
  std::string pvbatch;
  const char* env_pvbatch = std::getenv("CAPSFLOW_PVBATCH");
  if (env_pvbatch && *env_pvbatch) {
    pvbatch = find_program(env_pvbatch);
    if (pvbatch.empty())
      throw InputError(std::string("CAPSFLOW_PVBATCH=") + env_pvbatch + ": not an executable program (expected ParaView's pvbatch)");
  } else {
    pvbatch = find_program("pvbatch");
    if (pvbatch.empty())
      throw InputError(std::string("capsflow render needs ParaView's pvbatch, which is not on PATH: ") + kPackages +
                       " (or set CAPSFLOW_PVBATCH to a pvbatch)");
  }
  std::vector<std::string> argv;
  const fs::path tmp_dir = dir / (".render.tmp." + std::to_string(::getpid()));
  const char* display = std::getenv("DISPLAY");
  if (!(display && *display)) {
    // Debian's pvbatch draws through an X server: without a display, a virtual one (Xvfb) for the run of pvbatch.
    const std::string xvfb = find_program("xvfb-run");
    if (!xvfb.empty()) {
      if (find_program("xauth").empty())
        throw InputError("capsflow render: xvfb-run needs xauth, which is not on PATH: on Debian apt-get install xauth");
      // Server numbers from 100 + pid: two renders started at once do not race for the same one. -noreset: Xvfb
      // resets when its last client disconnects, and pvbatch, which connects several times, then failed about every
      // other start on a loaded machine ("bad X server connection").
      // -f: the X authority file in our temporary directory, not in a directory of xvfb-run's in /tmp, which it
      // removes only when it exits by itself (not when ended by a signal).
      argv = {xvfb, "-a", "-n", std::to_string(100 + ::getpid() % 400), "-f",
              fs::absolute(tmp_dir / "Xauthority").string(), "-s",
              "-screen 0 " + std::to_string(std::max(px.width, 1280)) + "x" + std::to_string(std::max(px.height, 1024)) +
                  "x24 -noreset"};
      argv.push_back(pvbatch);
    } else if (env_pvbatch && *env_pvbatch) {
      argv = {pvbatch, "--force-offscreen-rendering"};  // a pvbatch built for EGL or OSMesa needs no X server
    } else {
      throw InputError(std::string("capsflow render: no display ($DISPLAY is not set) and no xvfb-run to stand in for "
                                   "one (Debian's pvbatch draws through an X server): ") +
                       kPackages + " (or set CAPSFLOW_PVBATCH to a pvbatch built for offscreen rendering)");
    }
  } else {
    argv = {pvbatch};
  }
  std::string ffmpeg;
  if (o.movie) {
    ffmpeg = find_program("ffmpeg");
    if (ffmpeg.empty()) throw InputError("--movie needs ffmpeg, which is not on PATH: on Debian apt-get install ffmpeg");
  }
  const fs::path script = find_share_script(kScript, "capsflow render");

  std::vector<std::size_t> ranged = chosen;
  ranged.insert(ranged.end(), movie.begin(), movie.end());
  if (o.color != "species" && !range) range = field_range(o, ranged);

  // --- drawing into a temporary directory, then into place ----------------------------------------------------------
  // A file-system failure from here on (a full disk, a folder removed under us) ends in one line naming the file.
  try {
    CreatedDirs created(dir);
    try {
      fs::create_directories(dir);
    } catch (const fs::filesystem_error& e) {
      throw InputError("--out " + o.out + ": cannot create the directory (" + e.code().message() + ")");
    }
    if (::access(dir.c_str(), W_OK | X_OK) != 0)
      throw InputError("--out " + o.out + ": the directory is not writable (" + std::strerror(errno) + ")");
    // One render at a time in a folder, --force or not: two would draw into it at once and the last rename would win.
    const fs::path lock_path = dir / kLockName;
    FolderLock lock(lock_path, "capsflow render");
    if (!lock.held()) {
      const RunMarker& h = lock.holder();
      const bool here = h.host == this_host();
      throw InputError("--out " + o.out + ": another capsflow render is drawing into this folder (pid " +
                       std::to_string(h.pid) + (here ? "" : " on host " + h.host) + ", started " +
                       number_text(epoch_seconds() - h.started) + " s ago; its lock " + lock_path.string() +
                       "): wait for it to end or choose another --out (--force does not override a live render" +
                       (here ? ")" : "; if it is gone, remove the lock)"));
    }
    check_outputs();  // again under the lock: a render that ended meanwhile may have written them
    remove_stale_render_dirs(dir);
    TempDirGuard tmp{tmp_dir};
    fs::remove_all(tmp.path, ec);
    fs::create_directory(tmp.path);
    std::vector<std::pair<std::size_t, fs::path>> drawn;  // frame -> where pvbatch draws it
    for (std::size_t m = 0; m < movie.size(); ++m)
      drawn.emplace_back(movie[m], tmp.path / ("movie_" + padded(m, 6) + ".png"));
    for (std::size_t k : chosen)
      if (!std::binary_search(movie.begin(), movie.end(), k))
        drawn.emplace_back(k, tmp.path / ("frame_" + padded(k, 6) + ".png"));
    std::sort(drawn.begin(), drawn.end());
    auto drawn_png = [&](std::size_t k) {
      for (const auto& d : drawn)
        if (d.first == k) return d.second;
      return fs::path();
    };

    nlohmann::json job;
    job["xdmf"] = fs::absolute(xdmf).string();
    job["frame_count"] = nf;
    job["frames"] = nlohmann::json::array();
    for (const auto& [k, png] : drawn)
      job["frames"].push_back({{"index", k}, {"time", facts.frame_times[k]}, {"png", png.string()}});
    job["color"] = o.color;
    job["units"] = facts.units;
    job["range"] = range ? nlohmann::json::array({range->first, range->second}) : nlohmann::json::array({0.0, 1.0});
    job["species"] = facts.species;
    job["species_rgb"] = nlohmann::json::array();
    for (const auto& c : species_colours(facts)) job["species_rgb"].push_back({c[0], c[1], c[2]});
    job["view"] = o.view;
    job["box"] = {facts.Lx, facts.H, facts.Lz};
    job["size"] = {px.width, px.height};
    job["title"] = picture_title(o.run, facts);
    job["state"] = (tmp.path / "view.pvsm").string();
    const fs::path job_file = tmp.path / "job.json";
    {
      // Checked: a job cut short by a full disk would make pvbatch fail on its JSON instead of naming the disk.
      std::ofstream js(job_file);
      errno = 0;
      js << job.dump(1) << "\n";
      js.flush();
      const int err = !js ? (errno ? errno : EIO) : fault_point("write", job_file.string());
      if (err) throw std::system_error(err, std::generic_category(), "cannot write '" + job_file.string() + "'");
    }

    const bool talk = !o.quiet;
    if (talk) {
      log << "capsflow render: " << o.run << ": " << facts.capsules << " capsules, " << nf << " frames; colour "
          << o.color;
      if (range)
        log << " [" << facts.units << "], " << number_text(range->first) << " .. " << number_text(range->second);
      log << "\n" << std::flush;
    }
    argv.push_back(script.string());
    argv.push_back(job_file.string());
    ProgressBar drawing(log, talk, "drawing ", drawn.size());
    std::size_t done = 0;
    ProcessOptions po;
    po.stderr_file = tmp.path / "pvbatch.log";
    po.on_line = [&](const std::string& line) {
      if (line.rfind("capsflow-render: frame ", 0) == 0) drawing.update(++done);
      lock.beat();
    };
    po.own_group = true;  // xvfb-run, its Xvfb and pvbatch end with us, whatever ends us
    const ProcessResult pr = run_process(argv, po);
    if (!pr.started) return fail(argv[0] + ": cannot run it (" + std::strerror(pr.error) + ")");
    if (pr.signal) return stopped(pr.signal, pvbatch, dir);
    if (pr.status != 0 || done != drawn.size()) {
      const std::string why = failure_line(po.stderr_file);
      std::string hint;
      if (why.find("No module named") != std::string::npos && why.find("paraview") != std::string::npos)
        throw InputError(pvbatch + ": ParaView's Python modules are missing (" + why + "): on Debian apt-get install "
                         "python3-paraview");
      if (display && *display &&
          (why.find("X server") != std::string::npos || why.find("DISPLAY") != std::string::npos))
        hint = " (DISPLAY=" + std::string(display) + " cannot be used: unset DISPLAY to draw under xvfb-run)";
      if (const std::string full = disk_full(dir); !full.empty())
        return fail("--out " + o.out + ": " + full + ": " + pvbatch + " could not write its pictures (" + why +
                    "); nothing written");
      return fail(pvbatch + " failed (exit status " + std::to_string(pr.status) + ", " + std::to_string(done) + " of " +
                  std::to_string(drawn.size()) + " frames drawn): " + why + hint);
    }
    // It said it drew them all: are they there? (Debian's pvbatch 5.11 on a full disk deletes the picture it could not
    // finish and still reports the frame, with exit status 0.)
    std::vector<std::size_t> unwritten;
    for (const auto& [k, png] : drawn)
      if (!is_nonempty_file(png)) unwritten.push_back(k);
    const bool no_state = !is_nonempty_file(tmp.path / "view.pvsm");
    if (!unwritten.empty() || no_state) {
      if (const std::string full = disk_full(dir); !full.empty())
        return fail("--out " + o.out + ": " + full + ": " + pvbatch + " could not write its pictures; nothing written");
      const std::string log_says = failure_line(po.stderr_file);
      const std::string other = ": set CAPSFLOW_PVBATCH to a pvbatch that can save " +
                                std::string(unwritten.empty() ? "states" : "screenshots") +
                                (log_says == "no message" ? "" : " (its log: " + log_says + ")");
      if (unwritten.size() == drawn.size())
        return fail(pvbatch + " reported " + std::to_string(drawn.size()) +
                    " frames drawn but wrote no pictures into " + dir.string() + other);
      if (!unwritten.empty()) {
        const std::size_t k = unwritten.front();
        const auto pic = std::find_if(pictures.begin(), pictures.end(), [&](const auto& p) { return p.first == k; });
        return fail(pvbatch + " reported frame " + std::to_string(k) + " drawn but wrote no picture of it (for " +
                    (pic != pictures.end() ? pic->second : mp4).string() + ")" + other);
      }
      return fail(pvbatch + " wrote no ParaView state (for " + state.string() + ")" + other);
    }

    if (o.movie) {
      const fs::path encoded = tmp.path / "movie.mp4";
      std::vector<std::string> ff = {ffmpeg, "-hide_banner", "-nostdin", "-nostats", "-loglevel", "error",
                                     "-framerate", std::to_string(o.fps), "-i", (tmp.path / "movie_%06d.png").string(),
                                     "-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", "20", "-movflags", "+faststart",
                                     "-progress", "pipe:1", encoded.string()};
      ProgressBar encoding(log, talk, "encoding", movie.size());
      ProcessOptions fo;
      fo.stderr_file = tmp.path / "ffmpeg.log";
      fo.on_line = [&](const std::string& line) {
        if (line.rfind("frame=", 0) == 0)
          encoding.update(std::min<std::size_t>(std::strtoul(line.c_str() + 6, nullptr, 10), movie.size()));
        lock.beat();
      };
      fo.own_group = true;
      const ProcessResult fr = run_process(ff, fo);
      if (!fr.started) return fail(ffmpeg + ": cannot run it (" + std::strerror(fr.error) + ")");
      if (fr.signal) return stopped(fr.signal, ffmpeg, dir);
      if (fr.status != 0 || !fs::is_regular_file(encoded, ec))
        return fail(ffmpeg + " failed (exit status " + std::to_string(fr.status) + "): " +
                    failure_line(fo.stderr_file));
      encoding.update(movie.size());
    }
    // The outputs go into place through the atomic-file helpers (synced, renamed, the directory synced; counted by the
    // test-only fault injection like every other output: issue 55). A picture is copied, not moved: a movie frame
    // stays for the movie's sake. All or none: a failure part way puts back what was there.
    Placement placement(tmp.path);
    try {
      if (o.movie) {
        placement.keep(mp4);
        move_into_place(tmp.path / "movie.mp4", mp4);
      }
      for (const auto& [k, png] : pictures) {
        std::ifstream in(drawn_png(k), std::ios::binary);
        if (!in) throw std::system_error(errno, std::generic_category(), "cannot read '" + drawn_png(k).string() + "'");
        placement.keep(png);
        write_file_atomically(png, [&](std::ostream& os) { os << in.rdbuf(); });
      }
      placement.keep(state);
      move_into_place(tmp.path / "view.pvsm", state);
    } catch (...) {
      placement.undo();
      throw;
    }

    if (talk) {
      for (const auto& [k, png] : pictures)
        log << "  picture  " << png.string() << " (frame " << k << ", strain " << number_text(facts.frame_times[k])
            << ", " << px.width << " x " << px.height << ")\n";
      if (o.movie)
        log << "  movie    " << mp4.string() << " (" << movie.size() << " frames at " << o.fps << " per second, "
            << px.width << " x " << px.height << ")\n";
      log << "  ParaView " << state.string() << " (File > Load State: the same view, reading " << xdmf.string()
          << ")\n";
    }
    created.keep();
    return 0;
  } catch (const std::system_error& e) {
    return fail(file_failure(e, dir));
  }
}

}  // namespace capsflow
