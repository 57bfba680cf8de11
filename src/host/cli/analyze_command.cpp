// The implementation of analyze_command.hpp: `capsflow analyze`, the study's analysis of run outputs into analysis.h5.
#include "host/cli/analyze_command.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>

#include <nlohmann/json.hpp>

#include "capsflow_version.hpp"
#include "host/analysis/analysis.hpp"
#include "host/analysis/analysis_dynamics.hpp"
#include "host/analysis/analysis_profiles.hpp"
#include "host/base/fault_injection.hpp"
#include "host/base/atomic_file.hpp"
#include "host/physics/config.hpp"
#include "host/base/errors.hpp"
#include "host/base/h5_file.hpp"
#include "host/base/math_constants.hpp"
#include "host/run/run_layout.hpp"

namespace capsflow {

namespace fs = std::filesystem;
using namespace analysis;

namespace {

constexpr double kFlagVolume = 1e-3;  // issue 9: flag (not refuse) a capsule whose volume strayed beyond this

// summary.json is written by nlohmann-json (keys in the order written; doubles at full precision, the shortest text
// that reads back to the same bits; NaN and infinities as null).
using Json = nlohmann::ordered_json;

Json jnum(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

// The CSV tables' numbers: the shortest text that reads back to the same double, "null" when not finite.
std::string num(double v) {
  if (!std::isfinite(v)) return "null";
  char b[40];
  const std::to_chars_result r = std::to_chars(b, b + sizeof b, v);
  return std::string(b, r.ptr);
}

// A CSV field: quoted, with quotes doubled (RFC 4180); control characters as spaces.
std::string csv_quote(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"') o += "\"\"";
    else if (static_cast<unsigned char>(c) < 0x20) o += ' ';
    else o += c;
  }
  return o + "\"";
}

Json jest(const Estimate& e) {
  Json j;
  if (!e.defined) {
    j["value"] = nullptr;
    j["se"] = nullptr;
    j["reason"] = e.reason;
    return j;
  }
  j["value"] = jnum(e.value);
  j["se"] = jnum(e.se);
  if (!e.reason.empty()) j["note"] = e.reason;
  return j;
}

enum class Kind { Suspension, Pinned, Pair };
const char* kind_name(Kind k) { return k == Kind::Pinned ? "pinned" : k == Kind::Pair ? "pair" : "suspension"; }

struct LoadedRun {
  fs::path path;
  RunFile file;
  Config cfg;
  Kind kind = Kind::Suspension;
  RunSeries series;
  std::string set;  // box, count and the [[species]] Ca values: groups of one set differ only in fractions
};

bool is_run_file(const fs::path& p) {
  const std::string name = p.filename().string();
  const std::string ck = ".checkpoint.h5";
  return p.extension() == ".h5" && !(name.size() > ck.size() && name.compare(name.size() - ck.size(), ck.size(), ck) == 0) &&
         name.front() != '.';
}

std::vector<fs::path> collect(const std::vector<std::string>& inputs) {
  std::vector<fs::path> out;
  for (const std::string& in : inputs) {
    std::error_code ec;
    if (fs::is_directory(in, ec)) {
      std::vector<fs::path> found;
      for (auto it = fs::recursive_directory_iterator(in, ec); !ec && it != fs::recursive_directory_iterator();
           it.increment(ec))
        if (it->is_regular_file() && is_run_file(it->path())) found.push_back(it->path());
      std::sort(found.begin(), found.end());
      out.insert(out.end(), found.begin(), found.end());
    } else if (fs::exists(in, ec)) {
      out.emplace_back(in);
    } else {
      throw InputError(in + ": no such run file or directory");
    }
  }
  return out;
}

std::string fmtg(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

LoadedRun load(const fs::path& p) {
  LoadedRun r;
  r.path = p;
  r.file = read_run_file(p);
  r.cfg = parse_config(r.file.config_text, p.string() + ":/parameters/config");
  const RunFile& f = r.file;
  RunSeries& s = r.series;
  s.label = p.string();
  s.H = r.cfg.domain.H;
  s.Lx = r.cfg.domain.Lx;
  s.Lz = r.cfg.domain.Lz;
  s.radius = r.cfg.capsules.radius;
  s.np = f.np;
  bool one_radius = true;
  for (std::size_t i = 0; i < r.cfg.species.size(); ++i)
    one_radius = one_radius && r.cfg.species_radius(i) == r.cfg.capsules.radius;
  if (!one_radius) {
    s.capsule_radius.resize(f.np);
    for (std::size_t k = 0; k < f.np; ++k) {
      const auto sp = static_cast<std::size_t>(f.species.at(k));
      if (sp >= r.cfg.species.size())
        throw InputError(p.string() + ": /capsules/species out of range of its [[species]]");
      s.capsule_radius[k] = r.cfg.species_radius(sp);
    }
  }
  s.time = f.time;
  s.centroid = f.centroid;
  s.velocity = f.velocity;
  s.volume = f.volume;
  s.taylor_D = f.taylor_D;
  s.species.assign(f.species.begin(), f.species.end());
  s.ca = f.ca;
  s.pinned.assign(f.pinned.begin(), f.pinned.end());
  if (f.profile_bins > 0 && !f.profile.empty()) {
    s.slab_species = static_cast<int>(f.nspecies);
    s.slab_bins = static_cast<int>(f.profile_bins);
    s.slab_volume = f.profile;
  }
  bool all_pinned = f.np > 0;
  for (auto pin : f.pinned) all_pinned = all_pinned && pin;
  r.kind = all_pinned ? Kind::Pinned
                      : (r.cfg.flow.type == FlowType::Shear && f.np == 2) ? Kind::Pair : Kind::Suspension;
  std::vector<double> cas;
  for (const SpeciesSpec& sp : r.cfg.species) cas.push_back(sp.ca);
  std::sort(cas.begin(), cas.end());
  r.set = "H=" + fmtg(s.H) + " Lx=" + fmtg(s.Lx) + " Lz=" + fmtg(s.Lz) + " Np=" + std::to_string(f.np) + " Ca=";
  for (std::size_t i = 0; i < cas.size(); ++i) r.set += (i ? "/" : "") + fmtg(cas[i]);
  return r;
}

SpeciesCa species_of_set(const Config& cfg) {
  SpeciesCa ca;
  std::vector<double> v;
  for (const SpeciesSpec& sp : cfg.species) v.push_back(sp.ca);
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
  if (v.empty()) return ca;
  ca.stiff = v.front();
  if (v.size() >= 2) ca.floppy = v[1];
  if (v.size() > 2)
    throw InputError(cfg.source + ": " + std::to_string(v.size()) +
                     " species Ca values: the analysis handles binary suspensions (stiff = the smaller Ca)");
  return ca;
}

// The units of an analysis.h5 dataset from its path (docs/analysis.md), in the scales of docs/usage.md: velocities in
// gammadot a, lengths in a, times in strain units; d-bar is over H/2 and the profiles are normalised ("1"). A path
// without a rule is a bug (a dataset added without its units), not a silent gap.
std::string analysis_units(const std::string& path) {
  const std::string name = path.substr(path.rfind('/') + 1);
  auto within = [&](const char* part) { return path.find(part) != std::string::npos; };
  auto starts = [&](const char* prefix) { return name.rfind(prefix, 0) == 0; };
  if (within("/dbar_stats/")) return name == "block_length" ? "1/gammadot" : "1";
  if (name == "time") return "1/gammadot";
  if (within("/snapshot/")) return name == "positions" ? "a" : "1";
  if (within("/pdf/")) return name == "edges" ? "gammadot a" : "1/(gammadot a)";
  if (name == "separation" || name == "disp_top" || name == "disp_bottom") return "a";
  if (name == "uy_top" || name == "uy_bottom" || name == "V_S") return "gammadot a";
  if (within("/profiles/")) return starts("v_bar_") || starts("v_prime_") ? "gammadot a" : "1";
  if (within("/dbar_t/") || within("/curves/") || name == "y_over_H") return "1";
  throw std::logic_error("analysis.h5: no units for " + path);
}

void write_profile(H5File& f, const std::string& base, const std::string& name, const Profile& p) {
  if (!p.any_defined()) return;
  f.write(base + "/" + name, {p.value.size()}, p.value);
  f.write(base + "/" + name + "_se", {p.se.size()}, p.se);
}

// summary.json of a steady d-bar: the estimate (se null when not estimable, with the reason), the SE's rule, its lower
// bound, every estimator and the steadiness test (docs/output_format.md, "summary.json").
Json jdbar(const Estimate& e, const std::map<std::string, DBar>& stats, const std::string& sn) {
  Json j = jest(e);
  const auto it = stats.find(sn);
  if (!e.defined || it == stats.end()) return j;
  const DBar& d = it->second;
  const MeanError& m = d.error;
  if (!std::isfinite(e.se)) {  // the SE is null: say why once, as se_reason
    j.erase("note");
    j["se_reason"] = e.reason;
  }
  j["se_rule"] = d.se_rule;
  j["se_lower_bound"] = jnum(m.lower_bound);
  Json block = {{"se", m.block.defined ? jnum(m.block.value) : Json(nullptr)},
                {"block_length", jnum(m.block_length)},
                {"lower_bound", jnum(m.block_lower_bound)}};
  if (!m.block.defined) block["reason"] = m.block.reason;
  Json tau = {{"se", m.tau.defined ? jnum(m.tau.value) : Json(nullptr)}, {"tau_int", jnum(m.tau_int)}};
  if (!m.tau.defined) tau["reason"] = m.tau.reason;
  Json seeds = {{"runs", m.runs}, {"se", m.seeds.defined ? jnum(m.seeds.value) : Json(nullptr)}};
  if (!m.seeds.defined) seeds["reason"] = m.seeds.reason;
  j["errors"] = {{"block", block}, {"autocorrelation", tau}, {"realizations", seeds}};
  const HalvesTest& h = d.halves;
  j["halves"] = {{"first", {{"value", jnum(h.first.value)}, {"se", jnum(h.first.se)}}},
                 {"second", {{"value", jnum(h.second.value)}, {"se", jnum(h.second.se)}}},
                 {"difference", jnum(h.difference)},
                 {"z", jnum(h.z)},
                 {"verdict", h.verdict},
                 {"steady", h.steady}};
  return j;
}

// summary.json of f_AB: the estimate, the SE's rule, the events it rests on and both jackknifes.
Json jfab(const Estimate& e, const std::map<std::string, TransitionProbability>& stats, const std::string& sn) {
  Json j = jest(e);
  const auto it = stats.find(sn);
  if (!e.defined || it == stats.end()) return j;
  const TransitionProbability& t = it->second;
  if (!std::isfinite(e.se)) {
    j.erase("note");
    j["se_reason"] = e.reason;
  }
  j["se_rule"] = t.se_rule;
  j["hits"] = jnum(t.hits);
  j["starts"] = jnum(t.starts);
  j["origins"] = t.origins;
  j["crossings"] = jnum(t.crossings);
  j["capsules"] = t.capsules;
  j["capsules_crossing"] = t.capsules_crossing;
  j["se_capsules"] = jnum(t.se_capsules.se);
  j["se_time"] = jnum(t.se_time.se);
  j["subwindows"] = t.subwindows;
  j["subwindow_length"] = jnum(t.subwindow_length);
  return j;
}

// analysis.h5 /groups/gNNN/dbar_stats/<species>: the combined block sweep (datasets block_length, block_se,
// block_se_error) and the SE estimators and halves test as attributes (docs/output_format.md).
void write_dbar_stats(H5File& f, const std::string& path, const DBar& d) {
  if (!d.d.defined) return;
  const MeanError& m = d.error;
  f.create_group(path);
  if (!m.sweep_length.empty()) {
    f.write(path + "/block_length", {m.sweep_length.size()}, m.sweep_length);
    f.write(path + "/block_se", {m.sweep_se.size()}, m.sweep_se);
    f.write(path + "/block_se_error", {m.sweep_se_error.size()}, m.sweep_se_error);
  }
  f.set_attribute(path, "value", d.d.value);
  f.set_attribute(path, "se", d.d.se);
  f.set_attribute(path, "se_rule", d.se_rule);
  f.set_attribute(path, "se_lower_bound", m.lower_bound);
  f.set_attribute(path, "se_block", m.block.defined ? m.block.value : NAN);
  f.set_attribute(path, "block_usable_levels", static_cast<std::int64_t>(m.sweep_usable));
  f.set_attribute(path, "se_tau", m.tau.defined ? m.tau.value : NAN);
  f.set_attribute(path, "tau_int", m.tau_int);
  f.set_attribute(path, "se_realizations", m.seeds.defined ? m.seeds.value : NAN);
  f.set_attribute(path, "runs", static_cast<std::int64_t>(m.runs));
  f.set_attribute(path, "first_half", d.halves.first.value);
  f.set_attribute(path, "first_half_se", d.halves.first.se);
  f.set_attribute(path, "second_half", d.halves.second.value);
  f.set_attribute(path, "second_half_se", d.halves.second.se);
  f.set_attribute(path, "halves_z", d.halves.z);
  f.set_attribute(path, "steady", static_cast<std::int64_t>(d.halves.steady));
  f.set_attribute(path, "verdict", d.halves.verdict);
}

// analysis.h5 /groups/gNNN/fab/<species>: f_AB with the events it rests on, as attributes.
void write_fab_stats(H5File& f, const std::string& path, const TransitionProbability& t) {
  if (!t.f.defined) return;
  f.create_group(path);
  f.set_attribute(path, "value", t.f.value);
  f.set_attribute(path, "se", t.f.se);
  f.set_attribute(path, "se_rule", t.se_rule);
  f.set_attribute(path, "se_capsules", t.se_capsules.se);
  f.set_attribute(path, "se_time", t.se_time.se);
  f.set_attribute(path, "hits", t.hits);
  f.set_attribute(path, "starts", t.starts);
  f.set_attribute(path, "crossings", t.crossings);
  f.set_attribute(path, "capsules", static_cast<std::int64_t>(t.capsules));
  f.set_attribute(path, "capsules_crossing", static_cast<std::int64_t>(t.capsules_crossing));
  f.set_attribute(path, "subwindows", static_cast<std::int64_t>(t.subwindows));
  f.set_attribute(path, "subwindow_length", t.subwindow_length);
}

struct GroupResult {
  std::string key, set, label;
  Kind kind = Kind::Suspension;
  double x_f = NAN, H = 0, Lx = 0, Lz = 0;
  SpeciesCa ca;
  Window window;
  std::vector<const LoadedRun*> runs;
  std::map<std::string, Estimate> dbar, fab;  // by species name
  std::map<std::string, DBar> dstat;          // the statistics behind dbar (SE estimators, halves test)
  std::map<std::string, TransitionProbability> fstat;  // behind fab (events, the two jackknifes)
  std::map<std::string, std::size_t> count;
  Estimate E_s, E_f;
  std::map<std::string, Profile> v_bar;       // for the relative change against pure groups
  double drift = 0.0;
  std::vector<std::string> flags;
  Json extra = Json::object();  // kind-specific summary entries
  MigrationVelocity isolated;  // pinned groups: V^S of the first pinned capsule
};

// The output files of one analysis, staged under temporary names and renamed together (see run_analyze). The
// destructor undoes an analysis that did not reach the end of commit().
struct Outputs {
  std::vector<std::pair<fs::path, fs::path>> staged;  // temporary -> final name, in commit order
  std::vector<fs::path> committed;                    // final names renamed by this analysis
  std::vector<fs::path> made_dirs;                    // directories this analysis created, deepest first
  bool done = false;

  fs::path stage(const fs::path& final_name) {
    staged.emplace_back(temp_path_for(final_name), final_name);
    return staged.back().first;
  }
  [[noreturn]] static void fail(const std::string& what) {
    throw std::system_error(errno ? errno : EIO, std::generic_category(), what);
  }
  void stage_text(const fs::path& final_name, const std::string& text) {
    const fs::path tmp = stage(final_name);
    std::ofstream os(tmp, std::ios::binary | std::ios::trunc);
    if (!os) fail("cannot create '" + tmp.string() + "'");
    errno = 0;
    os.write(text.data(), static_cast<std::streamsize>(text.size()));
    os.flush();
    // The stream keeps no reason; errno still holds the failed write's (ENOSPC on a full disk).
    if (!os) fail("cannot write '" + final_name.string() + "'");
    if (const int err = fault_point("write", tmp.string())) {
      errno = err;
      fail("cannot write '" + final_name.string() + "'");
    }
    os.close();
    if (os.fail()) fail("cannot close '" + final_name.string() + "'");
    fsync_path(tmp);
  }
  void commit() {
    // The HDF5 file last: an analysis counts as present (and refused without --force) by analysis.h5 or
    // summary.json, so the renames run from the text tables to them.
    std::stable_partition(staged.begin(), staged.end(),
                          [](const auto& s) { return s.second.filename() != "analysis.h5"; });
    for (const auto& [tmp, final_name] : staged) {
      std::error_code ec;
      if (const int err = fault_point("rename", final_name.string())) ec = std::error_code(err, std::generic_category());
      else fs::rename(tmp, final_name, ec);
      if (ec) throw std::system_error(ec, "cannot rename '" + tmp.string() + "' to '" + final_name.string() + "'");
      committed.push_back(final_name);
    }
    if (!staged.empty()) {
      const fs::path dir = staged.front().second.parent_path();
      fsync_path(dir.empty() ? fs::path(".") : dir);
    }
    done = true;
  }
  ~Outputs() {
    if (done) return;
    std::error_code ec;
    for (const auto& st : staged) fs::remove(st.first, ec);
    for (const fs::path& p : committed) fs::remove(p, ec);
    for (const fs::path& d : made_dirs) fs::remove(d, ec);  // only when empty
  }
};


// ---- run_analyze's stages, in the order it runs them

// Where an analysis goes: the --out directory and the two files that mark an analysis there.
struct AnalysisPaths {
  fs::path out, h5, json;
};

// Refusals that need no run read: --out, --bins, an earlier analysis without --force.
AnalysisPaths check_output_options(const AnalyzeOptions& o) {
  if (o.out.empty()) throw InputError("--out: expected an output directory, got an empty string");
  if (o.bins < 1 || o.bins > 10000) throw InputError("--bins: expected an integer in 1..10000, got " + std::to_string(o.bins));
  const AnalysisPaths p{fs::path(o.out), fs::path(o.out) / "analysis.h5", fs::path(o.out) / "summary.json"};
  std::error_code ec;
  if (fs::exists(p.out, ec) && !fs::is_directory(p.out, ec))
    throw InputError(o.out + ": --out exists and is not a directory");
  if (!o.force && (fs::exists(p.h5, ec) || fs::exists(p.json, ec)))
    throw InputError(o.out + ": holds an earlier analysis (analysis.h5 / summary.json); pass --force to replace it");
  return p;
}

// Every run of the inputs loaded and classified (all reads before any write). A file found in a directory that is
// not a run output is skipped (said on `log`); one run given twice is refused.
std::vector<LoadedRun> load_runs(const AnalyzeOptions& o, std::ostream& log) {
  const std::vector<fs::path> paths = collect(o.inputs);
  std::vector<LoadedRun> runs;
  std::map<std::string, std::size_t> by_run_id;  // run id -> index in runs
  for (const fs::path& p : paths) {
    try {
      runs.push_back(load(p));
    } catch (const RunStoreFileError&) {
      throw;  // a run's records left out, or half of them: never skipped
    } catch (const InputError& e) {
      // A directory may hold other HDF5 files (an analysis.h5 of an earlier analysis): skip them when searching.
      if (std::find(o.inputs.begin(), o.inputs.end(), p.string()) != o.inputs.end()) throw;
      if (!o.quiet) log << "capsflow analyze: skipping " << p.string() << ": " << e.what() << "\n";
      continue;
    }
    // One run counts once: pooled twice, its samples would count double and understate every error bar. A run is
    // its run id (the root attribute run_id: a copy or a continuation keeps it); a file without one (none is
    // written without one) is known by its inode.
    const LoadedRun& r = runs.back();
    const LoadedRun* same = nullptr;
    if (!r.file.run_id.empty()) {
      const auto [it, fresh] = by_run_id.emplace(r.file.run_id, runs.size() - 1);
      if (!fresh) same = &runs[it->second];
    } else {
      for (std::size_t i = 0; i + 1 < runs.size() && !same; ++i) {
        std::error_code eq;
        if (fs::equivalent(runs[i].path, r.path, eq)) same = &runs[i];
      }
    }
    if (same) {
      const std::string id = r.file.run_id.empty() ? std::string() : " (run id " + r.file.run_id + ")";
      throw InputError(same->path.string() == r.path.string()
                           ? r.path.string() + ": the same run is given twice" + id +
                                 ": name each run once (a file, or a directory that holds it, not both)"
                           : same->path.string() + " and " + r.path.string() + " are the same run" + id +
                                 ": name each run once (a copy, a file named twice, or a directory and a file in "
                                 "it would pool it twice)");
    }
  }
  if (runs.empty()) throw InputError("no capsflow run output found in the inputs");
  return runs;
}

// The analysis options of the command line: --bins, and --window checked against every run.
AnalysisOptions analysis_options(const AnalyzeOptions& o, const std::vector<LoadedRun>& runs) {
  AnalysisOptions opt;
  opt.bins = o.bins;
  if (o.t0) {
    opt.window_start = *o.t0;
    opt.window_end = *o.t1;
    for (const LoadedRun& r : runs)
      if (r.series.records() == 0 || *o.t0 < r.series.time.front() - 1e-9 || *o.t1 > r.series.time.back() + 1e-9)
        throw InputError("--window " + num(*o.t0) + ":" + num(*o.t1) + ": outside run " + r.path.string() +
                         " (strain " + (r.series.records() ? num(r.series.time.front()) + " to " +
                                                                 num(r.series.time.back())
                                                           : std::string("none recorded")) +
                         ")");
  }
  return opt;
}

// Runs grouped by their physics (analyze_command.hpp, step 3): suspension runs pooled by composition, pinned and pair
// runs alone. The groups point into `runs`.
std::vector<GroupResult> group_runs(const std::vector<LoadedRun>& runs) {
  std::vector<GroupResult> groups;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const LoadedRun& r = runs[i];
    std::string key = kind_name(r.kind) + std::string(" ") + composition_key(r.series);
    if (r.kind != Kind::Suspension) key += " #" + std::to_string(i);  // pinned and pair runs stand alone
    auto gi = std::find_if(groups.begin(), groups.end(), [&](const GroupResult& g) { return g.key == key; });
    if (gi == groups.end()) {
      GroupResult g;
      g.key = key;
      g.set = r.set;
      g.kind = r.kind;
      g.H = r.series.H;
      g.Lx = r.series.Lx;
      g.Lz = r.series.Lz;
      g.ca = species_of_set(r.cfg);
      groups.push_back(g);
      gi = groups.end() - 1;
    }
    gi->runs.push_back(&r);
  }
  return groups;
}

// The CSV tables, filled group by group beside analysis.h5.
struct Tables {
  std::ostringstream curves, profiles, isolated, pairs;
  Tables() {
    curves << "set,x_f,species,dbar,dbar_se,E,E_se,f_AB,f_AB_se\n";
    profiles << "group,species,quantity,y_over_H,value,se\n";
    isolated << "ca,y0_over_H,V_S,steady,run\n";
    pairs << "run,ca_top,ca_bottom,final_top,final_bottom\n";
  }
};

// The output directory made, with the directories it took remembered in `outputs` (removed again when the analysis
// fails), after the kinds of the files it will hold are checked.
void make_output_dir(const AnalyzeOptions& o, const fs::path& out, Outputs& outputs) {
  std::error_code ec;
  for (const char* name : {"analysis.h5", "summary.json", "curves.csv", "profiles.csv", "isolated.csv", "pairs.csv"})
    check_output_kind(out / name);
  for (fs::path d = out; !d.empty() && !fs::exists(d, ec); d = d.parent_path()) {
    outputs.made_dirs.push_back(d);
    if (d == d.parent_path()) break;
  }
  fs::create_directories(out, ec);
  if (ec) throw std::system_error(ec, o.out + ": cannot create the output directory");  // I/O: exit 1
}

// A group's runs as the analysis library takes them, checked (validate_group), and the group's window.
RunGroup run_group(GroupResult& g, const AnalysisOptions& opt) {
  RunGroup rg;
  rg.key = g.key;
  rg.ca = g.ca;
  for (const LoadedRun* r : g.runs) rg.runs.push_back(r->series);
  validate_group(rg);
  g.window = steady_window(rg.runs.front(), opt);
  return rg;
}

// Capsules whose volume strayed beyond kFlagVolume are flagged, not refused.
void flag_volume_drift(GroupResult& g, const RunGroup& rg) {
  for (const RunSeries& s : rg.runs) {
    const VolumeDrift vd = volume_drift(s, kFlagVolume);
    g.drift = std::max(g.drift, vd.max_relative);
    if (!vd.flagged.empty())
      g.flags.push_back(s.label + ": " + std::to_string(vd.flagged.size()) + " capsule(s) with |V/V0 - 1| > 1e-3 (max " +
                        num(vd.max_relative) + ")");
  }
}

// Contact events and flow diagnostics of the fidelity issue, where the files have them (format 2).
void contact_and_flow(GroupResult& g, const AnalysisOptions& opt) {
  double events = 0.0, span = 0.0, sum_dy = 0.0, max_dy = 0.0;
  std::vector<double> flow_blocks;
  bool have_flow = false;
  for (const LoadedRun* r : g.runs) {
    const RunFile& rf = r->file;
    const Window w = steady_window(r->series, opt);
    span += w.t1 - w.t0;
    for (std::size_t e = 0; e < rf.events; ++e)
      if (rf.event_time[e] >= w.t0 && rf.event_time[e] <= w.t1) {
        events += 1.0;
        const double d = std::max(std::abs(rf.event_dy[2 * e]), std::abs(rf.event_dy[2 * e + 1]));
        sum_dy += d;
        max_dy = std::max(max_dy, d);
      }
    // A flow rate written before issue 37 with a viscosity ratio other than 1 counted the inner fluid with
    // weight lambda (run_layout.hpp, kAttrFlowRateRevision): not a number to average; said in the flags.
    if (r->cfg.flow.type == FlowType::Poiseuille && r->cfg.has_viscosity_contrast() &&
        rf.flow_rate_revision < layout::kFlowRateRevision) {
      g.flags.push_back(r->path.string() + ": flow_rate_ratio left out: written before issue 37 with a viscosity "
                        "ratio other than 1, it counts the fluid inside the capsules with weight lambda (rerun "
                        "the point for it)");
      continue;
    }
    const std::vector<double>& q =
        r->cfg.flow.type == FlowType::Shear ? rf.relative_viscosity : rf.flow_rate_ratio;
    if (q.size() == rf.records && !q.empty()) {
      const std::vector<int> blk = record_blocks(rf.time, w, opt.blocks);
      std::vector<double> sum(static_cast<std::size_t>(opt.blocks), 0.0), cnt(sum.size(), 0.0);
      for (std::size_t t = 0; t < q.size(); ++t)
        if (blk[t] >= 0 && std::isfinite(q[t])) {
          sum[static_cast<std::size_t>(blk[t])] += q[t];
          cnt[static_cast<std::size_t>(blk[t])] += 1.0;
        }
      for (std::size_t b = 0; b < sum.size(); ++b)
        if (cnt[b] > 0) flow_blocks.push_back(sum[b] / cnt[b]);
      have_flow = true;
    }
  }
  g.extra["contact"] = {{"events", jnum(events)},
                        {"events_per_strain", jnum(span > 0 ? events / span : NAN)},
                        {"mean_abs_dy", jnum(events > 0 ? sum_dy / events : NAN)},
                        {"max_abs_dy", jnum(max_dy)}};
  if (have_flow && !flow_blocks.empty()) {
    const bool shear = g.runs.front()->cfg.flow.type == FlowType::Shear;
    g.extra["flow"] = {{shear ? "relative_viscosity" : "flow_rate_ratio", jest(block_average(flow_blocks))}};
  }
}

// analysis.h5 /groups/gNNN: the group's identity, box, Ca and window as attributes.
void write_group_attributes(H5File& f, const std::string& base, const GroupResult& g) {
  f.create_group(base);
  std::string run_list;
  for (const LoadedRun* r : g.runs) run_list += (run_list.empty() ? "" : ",") + r->path.string();
  f.set_attribute(base, "key", g.key);
  f.set_attribute(base, "kind", kind_name(g.kind));
  f.set_attribute(base, "set", g.set);
  f.set_attribute(base, "runs", run_list);
  f.set_attribute(base, "H", g.H);
  f.set_attribute(base, "Lx", g.Lx);
  f.set_attribute(base, "Lz", g.Lz);
  f.set_attribute(base, "ca_stiff", g.ca.stiff);
  f.set_attribute(base, "ca_floppy", g.ca.floppy);
  f.set_attribute(base, "t0", g.window.t0);
  f.set_attribute(base, "t1", g.window.t1);
}

// A pinned group: the isolated capsule's migration velocity V^S. Pinned runs also get the suspension statistics
// (d-bar of the pinned heights, profiles).
void analyze_pinned(H5File& f, const std::string& base, GroupResult& g, const RunGroup& rg,
                    std::ostream& csv_isolated) {
  g.isolated = isolated_migration_velocity(rg.runs.front());
  const MigrationVelocity& mv = g.isolated;
  f.set_attribute(base, "ca", mv.ca);
  f.set_attribute(base, "y0_over_H", mv.y0_over_H);
  f.set_attribute(base, "V_S", mv.v_p.value);
  f.set_attribute(base, "steady", static_cast<std::int64_t>(mv.steady));
  f.set_attribute(base, "x_f", NAN);
  g.label = "pinned Ca " + fmtg(mv.ca) + " y/H " + fmtg(mv.y0_over_H);
  f.set_attribute(base, "label", g.label);
  csv_isolated << num(mv.ca) << "," << num(mv.y0_over_H) << "," << num(mv.v_p.value) << "," << mv.steady << ","
               << g.runs.front()->path.string() << "\n";
  g.extra["isolated"] = {{"capsule", mv.capsule},
                         {"ca", jnum(mv.ca)},
                         {"y0_over_H", jnum(mv.y0_over_H)},
                         {"V_S", jnum(mv.v_p.value)},
                         {"steady", static_cast<bool>(mv.steady)}};
}

// A pair group: the collision's separation, displacements and velocities.
void analyze_pair(H5File& f, const std::string& base, GroupResult& g, const RunGroup& rg, std::ostream& csv_pairs) {
  const PairCollision pc = pair_collision(rg.runs.front());
  f.write(base + "/time", {pc.time.size()}, pc.time);
  f.write(base + "/separation", {pc.separation.size()}, pc.separation);
  f.write(base + "/disp_top", {pc.top.displacement.size()}, pc.top.displacement);
  f.write(base + "/disp_bottom", {pc.bottom.displacement.size()}, pc.bottom.displacement);
  f.write(base + "/uy_top", {pc.top.velocity.size()}, pc.top.velocity);
  f.write(base + "/uy_bottom", {pc.bottom.velocity.size()}, pc.bottom.velocity);
  f.set_attribute(base, "ca_top", pc.top.ca);
  f.set_attribute(base, "ca_bottom", pc.bottom.ca);
  f.set_attribute(base, "final_top", pc.top.final_displacement.value);
  f.set_attribute(base, "final_bottom", pc.bottom.final_displacement.value);
  g.extra["pair"] = {{"ca_top", jnum(pc.top.ca)},
                     {"ca_bottom", jnum(pc.bottom.ca)},
                     {"final_top", jest(pc.top.final_displacement)},
                     {"final_bottom", jest(pc.bottom.final_displacement)}};
  f.set_attribute(base, "x_f", NAN);
  g.label = "pair Ca " + fmtg(pc.top.ca) + "|" + fmtg(pc.bottom.ca);
  f.set_attribute(base, "label", g.label);
  csv_pairs << g.runs.front()->path.string() << "," << num(pc.top.ca) << "," << num(pc.bottom.ca) << ","
            << num(pc.top.final_displacement.value) << "," << num(pc.bottom.final_displacement.value) << "\n";
}

// d-bar(t), the steady d-bar and f_AB per species (suspension and pinned groups).
void write_dbar_and_fab(H5File& f, const std::string& base, GroupResult& g, const RunGroup& rg,
                        const AnalysisOptions& opt) {
  const Species species[3] = {Species::Stiff, Species::Floppy, Species::All};
  // d-bar(t)
  const TimeSeries all_t = d_bar_series(rg, Species::All);
  f.write(base + "/dbar_t/time", {all_t.time.size()}, all_t.time);
  for (Species s : species) {
    const std::string sn = species_name(s);
    std::size_t n = 0;
    for (const RunSeries& r : rg.runs) n += species_count(r, s, rg.ca);
    g.count[sn] = n;
    TimeSeries ts = d_bar_series(rg, s);
    if (ts.value.size() != all_t.time.size()) ts.value.assign(all_t.time.size(), NAN);
    f.write(base + "/dbar_t/" + sn, {ts.value.size()}, ts.value);
    if (n == 0) {
      g.dbar[sn] = Estimate::undefined("no " + sn + " capsules in this group");
      g.fab[sn] = Estimate::undefined("no " + sn + " capsules in this group");
      continue;
    }
    g.dstat[sn] = steady_d_bar(rg, s, opt);
    g.dbar[sn] = g.dstat[sn].d;
    write_dbar_stats(f, base + "/dbar_stats/" + sn, g.dstat[sn]);
    if (s != Species::All) {
      g.fstat[sn] = transition_probability(rg, s, opt);
      g.fab[sn] = g.fstat[sn].f;
      write_fab_stats(f, base + "/fab/" + sn, g.fstat[sn]);
    }
  }
}

// The profiles per species (n, phi, v-bar, v'), the velocity PDFs at fixed heights and, for mixtures, enrichment.
void write_profiles(H5File& f, const std::string& base, std::size_t gi, GroupResult& g, const RunGroup& rg,
                    const AnalysisOptions& opt, std::ostream& csv_profiles) {
  const std::vector<double> pdf_heights = {0.2, 0.3, 0.4, 0.5};
  // Profiles. phi from the recorded mesh slabs when they fold exactly onto the bins, else the sphere model.
  const VolumeSource source = rg.runs.front().has_slabs() && rg.runs.front().slab_bins % (2 * opt.bins) == 0
                                  ? VolumeSource::MeshSlabs
                                  : VolumeSource::Spheres;
  std::vector<double> yk;
  for (Species s : {Species::Stiff, Species::Floppy}) {
    const std::string sn = species_name(s);
    if (g.count[sn] == 0) continue;
    const Profile n = number_density(rg, s, opt);
    if (yk.empty()) yk = n.y_over_H;
    write_profile(f, base + "/profiles", "n_hat_" + sn, n);
    const VolumeFractionProfile phi = volume_fraction_profile(rg, s, opt, source);
    write_profile(f, base + "/profiles", "phi_hat_" + sn, phi.phi_hat);
    const VelocityProfile v = velocity_profile(rg, s, opt);
    write_profile(f, base + "/profiles", "v_bar_" + sn, v.mean);
    write_profile(f, base + "/profiles", "v_prime_" + sn, v.fluctuation);
    g.v_bar[sn] = v.mean;
    const std::pair<const char*, const Profile*> rows[] = {
        {"n_hat", &n}, {"phi_hat", &phi.phi_hat}, {"v_bar", &v.mean}, {"v_prime", &v.fluctuation}};
    for (const auto& [q, p] : rows)
      for (std::size_t k = 0; k < p->value.size(); ++k)
        csv_profiles << gi << "," << sn << "," << q << "," << num(p->y_over_H[k]) << "," << num(p->value[k]) << ","
                     << num(p->se[k]) << "\n";
    for (double y0 : pdf_heights) {
      const VelocityPdf pdf = velocity_pdf(rg, s, y0, opt);
      if (pdf.samples == 0) continue;
      char pb[64];
      std::snprintf(pb, sizeof pb, "/pdf/%s/y%03d", sn.c_str(), static_cast<int>(std::lround(1000 * y0)));
      f.write(base + pb + "/edges", {pdf.edges.size()}, pdf.edges);
      f.write(base + pb + "/density", {pdf.density.size()}, pdf.density);
      f.set_attribute(base + pb, "samples", static_cast<std::int64_t>(pdf.samples));
      f.set_attribute(base + pb, "mean", pdf.mean);
      f.set_attribute(base + pb, "stddev", pdf.stddev);
    }
  }
  if (!yk.empty()) f.write(base + "/profiles/y_over_H", {yk.size()}, yk);
  if (g.count["stiff"] > 0 && g.count["floppy"] > 0) {
    const Enrichment en = enrichment(rg, opt, source);
    write_profile(f, base + "/profiles", "xf_hat", en.xf_hat);
    g.E_s = en.E_s;
    g.E_f = en.E_f;
    if (en.xf_volume_flag) g.flags.push_back("volume share of the floppy capsules differs from X_f by > 1 %");
  } else {
    g.E_s = g.E_f = Estimate::undefined("E is defined for mixtures only (0 < X_f < 1)");
  }
}

// One snapshot frame of the first run (fig. 2): the frame nearest the end of the window (frames fall at the
// first step at or past each multiple of frames_every, so the one at the window's end is often just past it).
void write_snapshot(H5File& f, const std::string& base, const GroupResult& g) {
  const RunFile& rf = g.runs.front()->file;
  if (rf.frames > 0) {
    std::size_t fr = 0;
    for (std::size_t k = 1; k < rf.frames; ++k)
      if (std::abs(rf.frame_time[k] - g.window.t1) < std::abs(rf.frame_time[fr] - g.window.t1)) fr = k;
    const H5File src = H5File::open(rf.path, H5Access::ReadShared);
    const auto pos = src.read_records<double>(layout::kFramePositions, fr, 1);
    const auto tri = src.read<std::int32_t>(layout::kMeshTrianglesAll);
    const auto ncap = src.read<std::int32_t>(layout::kMeshNodeCapsule);
    std::vector<std::int32_t> stiff(ncap.data.size());
    for (std::size_t i = 0; i < stiff.size(); ++i)
      stiff[i] = std::abs(rf.ca[static_cast<std::size_t>(ncap.data[i])] - g.ca.stiff) <= 1e-9 * g.ca.stiff;
    f.write(base + "/snapshot/positions", {pos.data.size() / 3, 3}, pos.data);
    f.write(base + "/snapshot/triangles", {tri.data.size() / 3, 3}, tri.data);
    f.write(base + "/snapshot/node_species_stiff", {stiff.size()}, stiff);
    f.set_attribute(base + "/snapshot", "time", rf.frame_time[fr]);
  }
}

// One group's statistics into analysis.h5 /groups/gNNN and the tables.
void analyze_group(H5File& f, std::size_t gi, GroupResult& g, const AnalysisOptions& opt, Tables& tables) {
  char name[32];
  std::snprintf(name, sizeof name, "/groups/g%03zu", gi);
  const std::string base = name;
  const RunGroup rg = run_group(g, opt);
  flag_volume_drift(g, rg);
  contact_and_flow(g, opt);
  write_group_attributes(f, base, g);
  if (g.kind == Kind::Pinned) analyze_pinned(f, base, g, rg, tables.isolated);
  if (g.kind == Kind::Pair) {
    analyze_pair(f, base, g, rg, tables.pairs);
    return;
  }

  // ---- suspension statistics (suspension and pinned groups)
  g.x_f = std::isfinite(g.ca.floppy) ? floppy_fraction(rg) : 0.0;
  if (g.kind == Kind::Suspension) {
    g.label = "Xf=" + fmtg(g.x_f) + " (" + g.set + ")";
    f.set_attribute(base, "label", g.label);
  }
  f.set_attribute(base, "x_f", g.x_f);
  write_dbar_and_fab(f, base, g, rg, opt);
  write_profiles(f, base, gi, g, rg, opt, tables.profiles);
  write_snapshot(f, base, g);
}

// Relative change of v-bar against the pure-species group of the same set (§9).
void write_relative_changes(H5File& f, const std::vector<GroupResult>& groups) {
  for (std::size_t gi = 0; gi < groups.size(); ++gi) {
    const GroupResult& g = groups[gi];
    if (g.kind != Kind::Suspension) continue;
    for (const char* sn : {"stiff", "floppy"}) {
      if (!g.v_bar.count(sn)) continue;
      const double pure_xf = std::string(sn) == "stiff" ? 0.0 : 1.0;
      for (const GroupResult& r : groups)
        if (&r != &g && r.kind == Kind::Suspension && r.set == g.set && r.x_f == pure_xf && r.v_bar.count(sn)) {
          char name[64];
          std::snprintf(name, sizeof name, "/groups/g%03zu/profiles", gi);
          write_profile(f, name, std::string("dv_rel_") + sn, relative_velocity_change(g.v_bar.at(sn), r.v_bar.at(sn)));
        }
    }
  }
}

// Curves against X_f per set (analysis.h5 /curves, curves.csv).
void write_curves(H5File& f, const std::vector<GroupResult>& groups, std::ostream& csv_curves) {
  std::vector<std::string> sets;
  for (const GroupResult& g : groups)
    if (g.kind == Kind::Suspension && std::find(sets.begin(), sets.end(), g.set) == sets.end()) sets.push_back(g.set);
  for (std::size_t si = 0; si < sets.size(); ++si) {
    std::vector<const GroupResult*> gs;
    for (const GroupResult& g : groups)
      if (g.kind == Kind::Suspension && g.set == sets[si]) gs.push_back(&g);
    std::sort(gs.begin(), gs.end(), [](const GroupResult* a, const GroupResult* b) { return a->x_f < b->x_f; });
    char name[32];
    std::snprintf(name, sizeof name, "/curves/c%03zu", si);
    const std::string base = name;
    std::map<std::string, std::vector<double>> col;
    for (const GroupResult* g : gs) {
      col["x_f"].push_back(g->x_f);
      for (const char* sn : {"stiff", "floppy", "all"}) {
        const Estimate& d = g->dbar.at(sn);
        col[std::string("dbar_") + sn].push_back(d.defined ? d.value : NAN);
        col[std::string("dbar_") + sn + "_se"].push_back(d.defined ? d.se : NAN);
        const auto ds = g->dstat.find(sn);
        const bool have = d.defined && ds != g->dstat.end();
        col[std::string("dbar_") + sn + "_se_lower_bound"].push_back(have ? ds->second.error.lower_bound : NAN);
        col[std::string("dbar_") + sn + "_halves_z"].push_back(have ? ds->second.halves.z : NAN);
      }
      for (const char* sn : {"stiff", "floppy"}) {
        const Estimate& fab = g->fab.at(sn);
        col[std::string("fab_") + sn].push_back(fab.defined ? fab.value : NAN);
        col[std::string("fab_") + sn + "_se"].push_back(fab.defined ? fab.se : NAN);
        const Estimate& E = std::string(sn) == "stiff" ? g->E_s : g->E_f;
        const std::string en = std::string("E_") + (std::string(sn) == "stiff" ? "s" : "f");
        col[en].push_back(E.defined ? E.value : NAN);
        col[en + "_se"].push_back(E.defined ? E.se : NAN);
        csv_curves << csv_quote(sets[si]) << "," << num(g->x_f) << "," << sn << "," << num(g->dbar.at(sn).value) << ","
                   << num(g->dbar.at(sn).se) << "," << num(E.value) << "," << num(E.se) << "," << num(fab.value)
                   << "," << num(fab.se) << "\n";
      }
    }
    for (const auto& [k, v] : col) f.write(base + "/" + k, {v.size()}, v);
    const GroupResult& g0 = *gs.front();
    f.set_attribute(base, "set", sets[si]);
    f.set_attribute(base, "ca_stiff", g0.ca.stiff);
    f.set_attribute(base, "ca_floppy", g0.ca.floppy);
    f.set_attribute(base, "H", g0.H);
    const double np = static_cast<double>(g0.runs.front()->file.np), a = g0.runs.front()->cfg.capsules.radius;
    const RunSeries& sr = g0.runs.front()->series;
    double vcaps = np * 4.0 / 3.0 * kPi * a * a * a;
    if (!sr.capsule_radius.empty()) {  // mixed sizes: sum the capsules' own volumes
      vcaps = 0.0;
      for (double r : sr.capsule_radius) vcaps += 4.0 / 3.0 * kPi * r * r * r;
    }
    f.set_attribute(base, "phi", vcaps / (g0.H * g0.Lx * g0.Lz));
    f.set_attribute(base, "two_a_over_H", 2.0 * a / g0.H);
  }
}

// The isolated V^S(y) per Ca (analysis.h5 /isolated).
void write_isolated_curves(H5File& f, const std::vector<GroupResult>& groups) {
  std::map<long, std::vector<std::pair<double, double>>> iso;
  for (const GroupResult& g : groups)
    if (g.kind == Kind::Pinned) iso[std::lround(1000 * g.isolated.ca)].push_back({g.isolated.y0_over_H, g.isolated.v_p.value});
  for (auto& [k, v] : iso) {
    std::sort(v.begin(), v.end());
    std::vector<double> y, V;
    for (const auto& [a, b] : v) {
      y.push_back(a);
      V.push_back(b);
    }
    char name[32];
    std::snprintf(name, sizeof name, "/isolated/ca%03ld", k);
    f.write(std::string(name) + "/y_over_H", {y.size()}, y);
    f.write(std::string(name) + "/V_S", {V.size()}, V);
    f.set_attribute(name, "ca", static_cast<double>(k) / 1000.0);
  }
}

// analysis.h5, written to its temporary name `path`: every group, then the curves across groups, then the units.
void write_analysis_h5(const fs::path& path, const AnalyzeOptions& o, const AnalysisOptions& opt,
                       std::vector<GroupResult>& groups, Tables& tables) {
  H5File f = H5File::create(path, true);
  f.set_attribute("/", "capsflow_version", CAPSFLOW_VERSION_STRING);
  f.set_attribute("/", "format", "capsflow-analysis");
  f.set_attribute("/", "format_version", std::int64_t{1});
  f.set_attribute("/", "bins", static_cast<std::int64_t>(o.bins));
  for (std::size_t gi = 0; gi < groups.size(); ++gi) analyze_group(f, gi, groups[gi], opt, tables);
  write_relative_changes(f, groups);
  write_curves(f, groups, tables.curves);
  write_isolated_curves(f, groups);
  for (const std::string& d : f.datasets()) f.set_attribute(d, "units", analysis_units(d));
  f.close();
}

// summary.json (docs/output_format.md).
Json summary_json(const AnalyzeOptions& o, const std::vector<GroupResult>& groups) {
  std::time_t now = std::time(nullptr);
  char when[64];
  std::strftime(when, sizeof when, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  Json js;
  js["capsflow_version"] = CAPSFLOW_VERSION_STRING;
  js["created"] = when;
  js["bins"] = o.bins;
  js["window_option"] = o.t0 ? Json::array({jnum(*o.t0), jnum(*o.t1)}) : Json(nullptr);
  js["groups"] = Json::array();
  for (std::size_t gi = 0; gi < groups.size(); ++gi) {
    const GroupResult& g = groups[gi];
    char id[32];
    std::snprintf(id, sizeof id, "g%03zu", gi);
    Json jg;
    jg["id"] = id;
    jg["kind"] = kind_name(g.kind);
    jg["key"] = g.key;
    jg["set"] = g.set;
    jg["label"] = g.label;
    jg["window"] = Json::array({jnum(g.window.t0), jnum(g.window.t1)});
    jg["window_rule"] = g.window.rule;
    jg["x_f"] = jnum(g.x_f);
    jg["runs"] = Json::array();
    for (const LoadedRun* r : g.runs) jg["runs"].push_back({{"path", r->path.string()}, {"run_id", r->file.run_id}});
    jg["volume_drift_max"] = jnum(g.drift);
    jg["flags"] = g.flags;
    for (const auto& [k, v] : g.extra.items()) jg[k] = v;
    if (g.kind != Kind::Pair) {
      Json sp = Json::object();
      for (const char* sn : {"stiff", "floppy"}) {
        const double ca = std::string(sn) == "stiff" ? g.ca.stiff : g.ca.floppy;
        if (!std::isfinite(ca)) continue;
        sp[sn] = {{"ca", jnum(ca)},
                  {"count", g.count.at(sn)},
                  {"dbar", jdbar(g.dbar.at(sn), g.dstat, sn)},
                  {"f_AB", jfab(g.fab.at(sn), g.fstat, sn)},
                  {"E", jest(std::string(sn) == "stiff" ? g.E_s : g.E_f)},
                  {"volume_drift_max", jnum(g.drift)}};
      }
      sp["all"] = {{"count", g.count.at("all")}, {"dbar", jdbar(g.dbar.at("all"), g.dstat, "all")}};
      jg["species"] = std::move(sp);
      // The steadiness test of docs/analysis.md §3 per species at a glance (details under species.*.dbar.halves).
      Json st = Json::object();
      for (const char* sn : {"stiff", "floppy", "all"})
        if (g.dstat.count(sn)) st[sn] = g.dstat.at(sn).halves.verdict;
      jg["steadiness"] = std::move(st);
    }
    js["groups"].push_back(std::move(jg));
  }
  return js;
}

// What the analysis found, on `log`: the groups, their windows, d-bar per species and the flags.
void print_analysis(std::ostream& log, const AnalyzeOptions& o, std::size_t run_count,
                    const std::vector<GroupResult>& groups) {
  log << "capsflow analyze: " << run_count << " run(s) in " << groups.size() << " group(s) -> " << o.out
      << " (analysis.h5, summary.json, curves.csv, profiles.csv, isolated.csv, pairs.csv)\n";
  for (const GroupResult& g : groups) {
    log << "  " << kind_name(g.kind) << "  " << g.label << "  runs " << g.runs.size() << "  window [" << fmtg(g.window.t0)
        << ", " << fmtg(g.window.t1) << "] (" << g.window.rule << ")\n";
    if (g.kind != Kind::Pair)
      for (const char* sn : {"stiff", "floppy", "all"}) {
        const Estimate& d = g.dbar.at(sn);
        if (!d.defined) continue;
        log << "    d-bar/(H/2) " << sn << " " << fmtg(d.value);
        const DBar& ds = g.dstat.at(sn);
        if (std::isfinite(d.se))
          log << " +- " << fmtg(d.se);
        else if (std::isfinite(ds.error.lower_bound))
          log << " (SE not estimable, at least " << fmtg(ds.error.lower_bound) << ")";
        else  // no usable block level at all: a short run or window
          log << " (SE not estimable: too few records in the window for blocks)";
        log << "; halves " << ds.halves.verdict;
        if (std::isfinite(ds.halves.z)) log << " (z = " << fmtg(ds.halves.z) << ")";
        log << "\n";
      }
    for (const std::string& fl : g.flags) log << "    flag: " << fl << "\n";
  }
}

}  // namespace

void parse_window(const std::string& text, AnalyzeOptions& o) {
  const std::size_t c = text.find(':');
  try {
    if (c == std::string::npos) throw std::invalid_argument("no colon");
    std::size_t used = 0;
    const double a = std::stod(text.substr(0, c), &used);
    if (used != c) throw std::invalid_argument("trailing");
    const std::string rest = text.substr(c + 1);
    const double b = std::stod(rest, &used);
    if (used != rest.size()) throw std::invalid_argument("trailing");
    if (!std::isfinite(a) || !std::isfinite(b) || !(b > a)) throw std::invalid_argument("order");
    o.t0 = a;
    o.t1 = b;
  } catch (const std::exception&) {
    throw InputError("--window: expected T0:T1 with finite strains T0 < T1, got '" + text + "'");
  }
}

int run_analyze(const AnalyzeOptions& o, std::ostream& log) {
  const AnalysisPaths paths = check_output_options(o);
  // ---- load, classify and group (all reads before any write)
  const std::vector<LoadedRun> runs = load_runs(o, log);
  const AnalysisOptions opt = analysis_options(o, runs);
  std::vector<GroupResult> groups = group_runs(runs);

  // Every output goes to a hidden temporary beside its final name first (temp_path_for: ".NAME.tmp.PID.N", which no
  // glob of run outputs picks up); only when all of them are complete are they renamed into place. A failure (a
  // full disk, an error in a group) removes the temporaries, the outputs already renamed by this analysis and the
  // directories it created: it leaves nothing that makes the rerun refuse ("holds an earlier analysis"), and an
  // earlier analysis is replaced only by a complete one.
  Outputs outputs;
  make_output_dir(o, paths.out, outputs);
  const fs::path tmp_h5 = outputs.stage(paths.h5);
  Tables tables;
  write_analysis_h5(tmp_h5, o, opt, groups, tables);
  const Json js = summary_json(o, groups);

  // ---- commit: every file staged, then all renamed (the HDF5 file last: with summary.json it marks an analysis)
  fsync_path(tmp_h5);
  outputs.stage_text(paths.json, js.dump(2) + "\n");
  outputs.stage_text(paths.out / "curves.csv", tables.curves.str());
  outputs.stage_text(paths.out / "profiles.csv", tables.profiles.str());
  outputs.stage_text(paths.out / "isolated.csv", tables.isolated.str());
  outputs.stage_text(paths.out / "pairs.csv", tables.pairs.str());
  outputs.commit();

  if (!o.quiet) print_analysis(log, o, runs.size(), groups);
  return 0;
}

}  // namespace capsflow
