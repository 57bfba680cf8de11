#pragma once
// Test helper for the physics validations (issue 4): builds run configurations of one or two capsules in code and
// drives capsflow::Simulation directly, recording per-step time series (Taylor D, inclination, centroids,
// volumes, volume-averaged velocities). Shared by tests/test_validation_reduced.cpp (default suite) and
// tests/validation_physics.cpp (label 'validation').
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "host/physics/config.hpp"
#include "host/physics/simulation.hpp"
#include "support/svg_plot.hpp"

namespace capsflow::test {

struct CapsuleSpecT {
  std::string species = "a";
  double x = 0.0, y = 0.0, z = 0.0;
  bool pinned = false;
};

struct RunSpec {
  double H = 8.0, Lx = 8.0, Lz = 8.0;
  double alpha = 2.0, alpha_hm = 0.5;
  std::string flow = "shear";  // "shear" | "poiseuille" | "none"
  int level = 2;
  double inflation = 0.0;
  std::vector<std::pair<std::string, double>> species{{"a", 0.3}};  // name, Ca
  std::vector<double> bending;  // [[species]] bending_modulus, per species (empty: none)
  std::vector<std::string> species_keys;  // per species: more [[species]] lines ("shape = \"biconcave\"\n...")
  double bending_cfl = 0.0;     // [time] bending_cfl (0: the default)
  std::vector<CapsuleSpecT> capsules;
  std::vector<std::array<double, 3>> axes;  // per capsule: [[capsule]] orientation (the symmetry axis); absent: none
  double end = 5.0;
  double cfl = 0.5;
  double min_gap = 0.02;
  std::string step_rule;  // [time] step_rule; empty: the default
  // D11's corrections (on by default since issue 8). The volume-drift validations switch both off: they measure
  // the scheme's discretisation error, which the corrections hide.
  bool velocity_projection = true, volume_correction = true;
};

inline std::string to_toml_text(const RunSpec& r) {
  std::ostringstream o;
  o.precision(17);
  o << "[domain]\nH = " << r.H << "\nLx = " << r.Lx << "\nLz = " << r.Lz << "\n";
  o << "[ggem]\nalpha = " << r.alpha << "\nalpha_hm = " << r.alpha_hm << "\n";
  o << "[run]\nbackend = \"threads\"\n";
  o << "[flow]\ntype = \"" << r.flow << "\"\nshear_rate = 1.0\n";
  // Drops only (every species "surface-tension"): no inflation, which a drop refuses.
  bool drops = !r.species.empty() && r.species_keys.size() >= r.species.size();
  for (std::size_t i = 0; drops && i < r.species.size(); ++i)
    drops = r.species_keys[i].find("\"surface-tension\"") != std::string::npos;
  o << "[capsules]\nmesh_level = " << r.level << "\n";
  if (!drops) o << "inflation = " << r.inflation << "\n";
  o << "velocity_projection = " << (r.velocity_projection ? "true" : "false") << "\nvolume_correction = "
    << (r.volume_correction ? "true" : "false") << "\n";
  for (std::size_t i = 0; i < r.species.size(); ++i) {
    o << "[[species]]\nname = \"" << r.species[i].first << "\"\nca = " << r.species[i].second << "\n";
    if (i < r.bending.size()) o << "bending_modulus = " << r.bending[i] << "\n";
    if (i < r.species_keys.size()) o << r.species_keys[i];
  }
  for (std::size_t k = 0; k < r.capsules.size(); ++k) {
    const CapsuleSpecT& c = r.capsules[k];
    o << "[[capsule]]\nspecies = \"" << c.species << "\"\ncenter = [" << c.x << ", " << c.y << ", " << c.z << "]\n";
    if (c.pinned) o << "pinned = true\n";
    if (k < r.axes.size()) o << "orientation = [" << r.axes[k][0] << ", " << r.axes[k][1] << ", " << r.axes[k][2] << "]\n";
  }
  o << "[time]\nend = " << r.end << "\ncfl = " << r.cfl << "\nmin_gap = " << r.min_gap << "\n";
  if (!r.step_rule.empty()) o << "step_rule = \"" << r.step_rule << "\"\n";
  if (r.bending_cfl > 0.0) o << "bending_cfl = " << r.bending_cfl << "\n";
  return o.str();
}

// One record per step (before the step): time, and per capsule D, inclination, volume, area, unwrapped centroid,
// volume-averaged velocity (3 each; for a pinned capsule: before the pin correction, i.e. its migration velocity).
struct Series {
  std::vector<double> t;
  std::vector<double> max_node_speed;  // over all nodes
  std::vector<std::vector<double>> D, incl, vol, area, cx, cy, cz, ux, uy, uz;
  long steps = 0;
  double min_pair_gap = std::numeric_limits<double>::infinity();  // two or more capsules: closest gap below h_e
  std::string stop;  // empty, or the stop reason's message
  double wall_s = 0.0;
};

// Runs to time `end` (or until `done(series)` returns true after a record, or a stop reason).
inline Series run_series(const RunSpec& spec, double end, int record_every = 1,
                         const std::function<bool(const Series&)>& done = {}) {
  Config cfg = parse_config(to_toml_text(spec), "<validation>");
  Simulation sim(cfg);
  const std::size_t n = spec.capsules.size();
  Series s;
  for (auto* v : {&s.D, &s.incl, &s.vol, &s.area, &s.cx, &s.cy, &s.cz, &s.ux, &s.uy, &s.uz}) v->resize(n);
  auto record = [&]() {
    sim.evaluate();
    const CapsuleGeometry g = sim.geometry();
    const std::vector<double> c = sim.unwrapped_centroids(g);
    const std::vector<double>& U = sim.capsule_velocity();
    s.t.push_back(sim.time());
    double umax = 0.0;
    for (std::size_t i = 0; i < sim.ux().size(); ++i)
      umax = std::max(umax, std::hypot(sim.ux()[i], sim.uy()[i], sim.uz()[i]));
    s.max_node_speed.push_back(umax);
    if (n >= 2) s.min_pair_gap = std::min(s.min_pair_gap, sim.closing_limits().pair_gap);
    for (std::size_t k = 0; k < n; ++k) {
      s.D[k].push_back(g.deformation[k].D);
      s.incl[k].push_back(g.deformation[k].inclination);
      s.vol[k].push_back(g.volume[k]);
      s.area[k].push_back(g.area[k]);
      s.cx[k].push_back(c[3 * k]);
      s.cy[k].push_back(c[3 * k + 1]);
      s.cz[k].push_back(c[3 * k + 2]);
      s.ux[k].push_back(U[3 * k]);
      s.uy[k].push_back(U[3 * k + 1]);
      s.uz[k].push_back(U[3 * k + 2]);
    }
  };
  const auto t0 = std::chrono::steady_clock::now();
  while (sim.time() < end - 1e-12) {
    if (s.steps % record_every == 0) {
      record();
      if (done && done(s)) break;
    }
    const StepInfo info = sim.advance();
    if (info.stop != StopReason::None) {
      s.stop = info.message;
      break;
    }
    ++s.steps;
  }
  if (s.t.empty() || s.t.back() != sim.time()) record();
  s.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

// Mean of v over the records with t in [t_from, t_to].
inline double window_mean(const Series& s, const std::vector<double>& v, double t_from, double t_to) {
  double sum = 0.0;
  int cnt = 0;
  for (std::size_t i = 0; i < s.t.size(); ++i)
    if (s.t[i] >= t_from && s.t[i] <= t_to) {
      sum += v[i];
      ++cnt;
    }
  return cnt ? sum / cnt : std::nan("");
}

// Value at the last record with t <= t_at (linear interpolation between records).
inline double value_at(const Series& s, const std::vector<double>& v, double t_at) {
  for (std::size_t i = 1; i < s.t.size(); ++i)
    if (s.t[i] >= t_at) {
      const double w = (t_at - s.t[i - 1]) / (s.t[i] - s.t[i - 1]);
      return (1 - w) * v[i - 1] + w * v[i];
    }
  return v.back();
}

// Least-squares slope of v(t) over [t_from, t_to].
inline double window_slope(const Series& s, const std::vector<double>& v, double t_from, double t_to) {
  double st = 0, sv = 0, stt = 0, stv = 0;
  int cnt = 0;
  for (std::size_t i = 0; i < s.t.size(); ++i)
    if (s.t[i] >= t_from && s.t[i] <= t_to) {
      st += s.t[i];
      sv += v[i];
      stt += s.t[i] * s.t[i];
      stv += s.t[i] * v[i];
      ++cnt;
    }
  if (cnt < 2) return std::nan("");
  return (cnt * stv - st * sv) / (cnt * stt - st * st);
}

// A pair collision in simple shear (KG pair collisions; docs/validation.md, VD 6): the top capsule starts at
// (Lx/2 - x_half, H/2 + 0.25), the bottom one at (Lx/2 + x_half, H/2 - 0.25); the run ends when their x separation
// is back to +2 x_half (or at strain 30).
struct PairResult {
  double dy_top = 0, dy_bottom = 0, dy_final = 0;
  Series s;
};

inline PairResult pair_run(double ca_top, double ca_bottom, int level, double H, double Lx, double Lz, double alpha,
                    double x_half, double cfl = 0.5, const std::string& step_rule = "", double dy_initial = 0.5,
                    const std::string& species_keys = "") {
  RunSpec r;
  r.H = H;
  r.Lx = Lx;
  r.Lz = Lz;
  r.alpha = alpha;
  r.level = level;
  r.inflation = 0.1;
  r.cfl = cfl;
  r.species = {{"top", ca_top}, {"bottom", ca_bottom}};
  if (!species_keys.empty()) r.species_keys = {species_keys, species_keys};
  r.step_rule = step_rule;
  r.capsules = {{"top", Lx / 2 - x_half, H / 2 + dy_initial / 2, Lz / 2},
                {"bottom", Lx / 2 + x_half, H / 2 - dy_initial / 2, Lz / 2}};
  PairResult out;
  out.s = run_series(r, 30.0, 2, [&](const Series& s) { return s.cx[0].back() - s.cx[1].back() >= 2 * x_half; });
  const Series& s = out.s;
  out.dy_top = s.cy[0].back() - s.cy[0].front();
  out.dy_bottom = s.cy[1].back() - s.cy[1].front();
  out.dy_final = s.cy[0].back() - s.cy[1].back();
  return out;
}

// The source tree: $CAPSFLOW_SOURCE_DIR (or the compiled-in default); empty when neither is known.
inline std::string source_dir() {
  std::string dir;
  if (const char* env = std::getenv("CAPSFLOW_SOURCE_DIR"); env && *env) dir = env;
#ifdef CAPSFLOW_TEST_DEFAULT_SOURCE_DIR
  if (dir.empty()) dir = CAPSFLOW_TEST_DEFAULT_SOURCE_DIR;
#endif
  return dir;
}

// A shipped preset, examples/presets/NAME.toml (docs/presets.md).
inline std::string preset_path(const std::string& name) { return source_dir() + "/examples/presets/" + name + ".toml"; }

// Where validation runs put their figures and number tables: $CAPSFLOW_VALIDATION_OUT, else validation-figures/ in
// the build tree (beside the test programs' capsflow), never the committed docs/figures: a test run must not rewrite
// what the docs quote (a result goes there on purpose, copied with the run it came from: docs/validation.md).
inline std::string figures_dir() {
  if (const char* env = std::getenv("CAPSFLOW_VALIDATION_OUT"); env && *env) return env;
  std::string binary;
  if (const char* env = std::getenv("CAPSFLOW_BINARY"); env && *env) binary = env;
#ifdef CAPSFLOW_TEST_DEFAULT_BINARY
  if (binary.empty()) binary = CAPSFLOW_TEST_DEFAULT_BINARY;
#endif
  if (binary.empty()) return {};
  return (std::filesystem::path(binary).parent_path() / "validation-figures").string();
}

// Writes `text` to figures_dir()/name (nothing when the directory is unknown); returns the path written.
inline std::string write_figure_file(const std::string& name, const std::string& text) {
  const std::string dir = figures_dir();
  if (dir.empty()) return {};
  std::printf("  (%s/%s)\n", dir.c_str(), name.c_str());
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  const std::string path = dir + "/" + name;
  std::ofstream f(path);
  f << text;
  return f ? path : std::string{};
}

}  // namespace capsflow::test
