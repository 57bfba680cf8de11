// The implementation of sweep.hpp: `capsflow sweep`, many runs of one study: plan, local, Slurm, status.
#include "host/cli/sweep.hpp"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <nlohmann/json.hpp>
#include <toml++/toml.h>

#include <algorithm>
#include <charconv>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <map>
#include <ostream>
#include <set>
#include <iostream>
#include <sstream>

#include "host/base/printable.hpp"
#include "host/base/atomic_file.hpp"
#include "host/base/build_info.hpp"
#include "host/base/errors.hpp"
#include "host/solver/ggem_solver.hpp"
#include "host/physics/config_toml.hpp"
#include "host/physics/initial_conditions.hpp"
#include "host/run/checkpoint.hpp"
#include "host/run/run_driver.hpp"
#include "host/run/run_layout.hpp"
#include "host/run/run_estimate.hpp"
#include "host/run/run_marker.hpp"
#include "host/run/stop_signal.hpp"
#include "kernels/backend.hpp"

namespace capsflow {

namespace fs = std::filesystem;

namespace {

std::string read_text(const fs::path& p, const std::string& what) {
  std::ifstream in(p, std::ios::binary);
  if (!in) throw InputError(p.string() + ": cannot open the " + what + ": " + std::strerror(errno));
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string fmt(double v, const char* f = "%.6g") {
  char b[48];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

// TOML text of a value node (what an override's value is).
std::string toml_text(const toml::node& n) {
  if (const auto* str = n.as_string()) {
    std::string q = "\"";
    for (char c : str->get()) {
      if (c == '"' || c == '\\') q += '\\';
      if (static_cast<unsigned char>(c) < 0x20) {
        char b[8];
        std::snprintf(b, sizeof b, "\\u%04x", c);
        q += b;
        continue;
      }
      q += c;
    }
    return q + "\"";
  }
  if (const auto* a = n.as_array()) {
    std::string s = "[";
    for (std::size_t i = 0; i < a->size(); ++i) s += (i ? ", " : "") + toml_text(*a->get(i));
    return s + "]";
  }
  if (const auto* d = n.as_floating_point()) {
    if (!std::isfinite(d->get())) return d->get() != d->get() ? "nan" : d->get() > 0 ? "inf" : "-inf";
    // The shortest text that reads back to the same double (10 -> "10.0", 0.1 -> "0.1", 1e-7 -> "1e-07").
    char b[64];
    const auto r = std::to_chars(b, b + sizeof b, d->get());
    std::string s(b, r.ptr);
    if (s.find_first_of(".eE") == std::string::npos) s += ".0";  // stays a float in TOML
    return s;
  }
  if (const auto* i = n.as_integer()) return std::to_string(i->get());
  if (const auto* b = n.as_boolean()) return b->get() ? "true" : "false";
  throw InputError("a value of a type an override cannot take (dates, tables)");
}

// A value as it appears in a directory name: numbers shortest, arrays joined by '_', unsafe characters -> '.'.
std::string name_text(const toml::node& n) {
  if (const auto* a = n.as_array()) {
    std::string s;
    for (std::size_t i = 0; i < a->size(); ++i) s += (i ? "_" : "") + name_text(*a->get(i));
    return s;
  }
  std::string s = n.is_string() ? std::string(n.as_string()->get()) : toml_text(n);
  if (n.is_floating_point() && s.size() > 2 && s.compare(s.size() - 2, 2, ".0") == 0) s.resize(s.size() - 2);
  for (char& c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '+' || c == '-')) c = '.';
  return s.empty() ? "empty" : s;
}

// Leaves of a table as dotted keys (quoted keys keep their dots: "species.2.ca" = ... and species.2.ca = ... are the
// same key).
void flatten(const toml::table& t, const std::string& prefix, std::vector<std::pair<std::string, const toml::node*>>& out) {
  for (const auto& [k, v] : t) {
    const std::string key = prefix.empty() ? std::string(k.str()) : prefix + "." + std::string(k.str());
    if (const auto* sub = v.as_table())
      flatten(*sub, key, out);
    else
      out.emplace_back(key, &v);
  }
}

std::string last_part(const std::string& key) {
  const std::size_t dot = key.rfind('.');
  return dot == std::string::npos ? key : key.substr(dot + 1);
}

// --- run-control keys: what a point may change without making its directory another point's -----------------

Config normalized(Config c) {
  c.time.end = 1.0;
  c.run.backend = Backend::Serial;
  c.run.threads = 0;
  c.output.file = "output.h5";
  c.source.clear();
  return c;
}

// The first line where two TOML texts differ, with the section it is in: "[suspension] seed = 2 (stored: 3)".
std::string first_difference(const std::string& want, const std::string& have) {
  std::istringstream a(want), b(have);
  std::string la, lb, section;
  while (true) {
    const bool ga = static_cast<bool>(std::getline(a, la)), gb = static_cast<bool>(std::getline(b, lb));
    if (!ga && !gb) return "";
    if (!ga) la.clear();
    if (!gb) lb.clear();
    if (la != lb) return (section.empty() ? "" : section + " ") + la + " (stored: " + lb + ")";
    if (!la.empty() && la[0] == '[') section = la;
  }
}

// --- results -------------------------------------------------------------------------------------------------

std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

bool is_interrupt(int code) { return code > 128 && code < 128 + 65; }

std::string hms(double seconds) {
  const long s = static_cast<long>(std::ceil(std::max(0.0, seconds)));
  char b[48];
  if (s >= 86400)
    std::snprintf(b, sizeof b, "%ld-%02ld:%02ld:%02ld", s / 86400, s / 3600 % 24, s / 60 % 60, s % 60);
  else
    std::snprintf(b, sizeof b, "%02ld:%02ld:%02ld", s / 3600, s / 60 % 60, s % 60);
  return b;
}

std::string human_time(double seconds) {
  if (seconds < 120) return fmt(seconds, "%.0f s");
  if (seconds < 7200) return fmt(seconds / 60, "%.0f min");
  if (seconds < 3 * 86400) return fmt(seconds / 3600, "%.1f h");
  return fmt(seconds / 86400, "%.1f d");
}

std::string human_bytes(double b) {
  if (b < 1e6) return fmt(b / 1e3, "%.0f kB");
  if (b < 1e9) return fmt(b / 1e6, "%.0f MB");
  return fmt(b / 1e9, "%.1f GB");
}

// --- values that go into file names and the Slurm script -----------------------------------------------------

bool control_char(char ch) {
  const unsigned char c = static_cast<unsigned char>(ch);
  return c < 0x20 || c == 0x7f;
}
bool has_control(const std::string& s) { return std::any_of(s.begin(), s.end(), control_char); }

bool name_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '+' || c == '-';
}

// The job and script name (`name`, or the sweep file's stem): a token that needs no quoting anywhere and cannot
// leave ROOT/slurm/.
constexpr std::size_t kMaxNameLength = 128;
const char* const kNameRule =
    "1 to 128 characters from A-Z a-z 0-9 . _ + -, starting with a letter or a digit";
bool valid_job_name(const std::string& n) {
  return !n.empty() && n.size() <= kMaxNameLength && std::isalnum(static_cast<unsigned char>(n.front())) &&
         std::all_of(n.begin(), n.end(), name_char);
}

std::string when(double epoch) {
  const std::time_t t = static_cast<std::time_t>(epoch);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%d %H:%M:%SZ", &tm);
  return b;
}

}  // namespace

// JSON through nlohmann-json: every number in the shortest text that reads back to the same double.
void write_sweep_result(const fs::path& p, const SweepResult& r) {
  nlohmann::ordered_json j;
  j["exit_code"] = r.exit_code;
  j["strain"] = r.strain;
  j["end"] = r.end;
  j["finished"] = r.finished;
  j["message"] = one_line(r.message);
  // A message may carry any bytes a path held: invalid UTF-8 is replaced rather than refused.
  write_file_atomically(p, j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

std::optional<SweepResult> read_sweep_result(const fs::path& p) {
  std::ifstream in(p);
  if (!in) return std::nullopt;
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  SweepResult r;
  r.exit_code = 1;  // a torn or foreign file reads as a failed attempt
  const std::size_t first = text.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && text[first] == '{') {
    const nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (!j.is_object()) return r;
    const auto number = [&](const char* k, double& v) {
      if (j.contains(k) && j[k].is_number()) v = j[k].get<double>();
    };
    if (j.contains("exit_code") && j["exit_code"].is_number_integer()) r.exit_code = j["exit_code"].get<int>();
    number("strain", r.strain);
    number("end", r.end);
    number("finished", r.finished);
    if (j.contains("message") && j["message"].is_string()) r.message = j["message"].get<std::string>();
    return r;
  }
  // The format before 2026-12-07: one `key = value` per line (results kept from earlier sweeps still read).
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    const std::size_t eq = line.find(" = ");
    if (eq == std::string::npos) continue;
    const std::string k = line.substr(0, eq), v = line.substr(eq + 3);
    try {
      if (k == "exit_code") r.exit_code = std::stoi(v);
      else if (k == "strain") r.strain = std::stod(v);
      else if (k == "end") r.end = std::stod(v);
      else if (k == "finished") r.finished = std::stod(v);
      else if (k == "message") r.message = v;
    } catch (...) {
    }
  }
  return r;
}

// ---------------------------------------------------------------------------------------------------------------
// The sweep file

Sweep load_sweep(const std::string& path) {
  const fs::path file(path);
  const std::string text = read_text(file, "sweep file");
  toml::table root;
  try {
    root = toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    const auto& where = e.source().begin;
    throw InputError(path + ":" + std::to_string(where.line) + ":" + std::to_string(where.column) +
                     ": invalid TOML: " + one_line(std::string(e.description())));
  }
  const fs::path here = file.parent_path();
  auto resolve = [&](const std::string& p) {
    return (fs::path(p).is_absolute() ? fs::path(p) : here / p).lexically_normal();
  };
  auto string_key = [&](const toml::table& t, const char* key, const std::string& where) -> std::optional<std::string> {
    const toml::node* n = t.get(key);
    if (!n) return std::nullopt;
    if (!n->is_string() || n->as_string()->get().empty())
      throw InputError(path + ": " + where + key + ": expected a non-empty string (a path)");
    return n->as_string()->get();
  };

  Sweep s;
  s.file = file;
  for (const auto& [k, v] : root) {
    const std::string key(k.str());
    if (key != "base" && key != "root" && key != "name" && key != "set" && key != "product" && key != "point")
      throw InputError(path + ": unknown key '" + key + "' (expected base, root, name, [set], [[product]], [[point]])");
  }
  const std::optional<std::string> base = string_key(root, "base", "");
  const std::optional<std::string> out_root = string_key(root, "root", "");
  if (!out_root) throw InputError(path + ": root: required (the directory that receives one directory per point)");
  s.root = resolve(*out_root).lexically_normal();
  if (const toml::node* n = root.get("name")) {
    // The Slurm job name and the script's file name ROOT/slurm/NAME.sbatch: a plain token, so that it can neither
    // break a line of the script nor name a file outside ROOT/slurm/.
    const std::string given = n->is_string() ? std::string(n->as_string()->get()) : std::string();
    if (!n->is_string() || !valid_job_name(given))
      throw InputError(path + ": name: expected " + kNameRule + " (the Slurm job and script name), got " +
                       (n->is_string() ? "'" + printable(given) + "'" : std::string("a value that is not a string")));
    s.name = given;
  } else {
    s.name = file.stem().string();  // checked by --slurm, the only verb that uses it (valid_job_name)
  }

  std::vector<ConfigOverride> common;
  if (const toml::node* set = root.get("set")) {
    if (!set->is_table()) throw InputError(path + ": set: expected a table [set] of overrides");
    std::vector<std::pair<std::string, const toml::node*>> leaves;
    flatten(*set->as_table(), "", leaves);
    for (const auto& [k, v] : leaves) common.push_back({k, toml_text(*v), path + ": [set] " + k});
  }

  struct Block {
    std::string label;
    fs::path base;
    std::vector<std::pair<std::string, std::vector<const toml::node*>>> lists;  // key -> values (one for a point)
  };
  std::vector<Block> blocks;
  for (const char* kind : {"product", "point"}) {
    const toml::node* arr = root.get(kind);
    if (!arr) continue;
    if (!arr->is_array_of_tables())
      throw InputError(path + ": " + kind + ": expected an array of tables [[" + kind + "]]");
    std::size_t i = 0;
    for (const toml::node& item : *arr->as_array()) {
      Block b;
      b.label = std::string("[[") + kind + "]] " + std::to_string(++i);
      const toml::table& t = *item.as_table();
      const std::optional<std::string> own_base = string_key(t, "base", b.label + " ");
      if (!own_base && !base) throw InputError(path + ": base: required (the base configuration, e.g. a preset)");
      b.base = resolve(own_base ? *own_base : *base);
      std::vector<std::pair<std::string, const toml::node*>> leaves;
      flatten(t, "", leaves);
      for (const auto& [k, v] : leaves) {
        if (k == "base") continue;
        std::vector<const toml::node*> values;
        if (std::string(kind) == "product") {
          if (!v->is_array() || v->as_array()->empty())
            throw InputError(path + ": " + b.label + " " + k + ": expected a non-empty array of values");
          for (const toml::node& x : *v->as_array()) values.push_back(&x);
        } else {
          values.push_back(v);
        }
        b.lists.emplace_back(k, values);
      }
      blocks.push_back(std::move(b));
    }
  }
  if (blocks.empty())
    throw InputError(path + ": no points: add a [[product]] of value lists or a [[point]] (docs/sweeps.md)");

  // The number of points, before any is made: a product of long lists is refused by its size, not by the memory
  // its enumeration exhausts.
  {
    std::size_t total = 0;
    for (const Block& b : blocks) {
      std::size_t combos = 1;
      std::string sizes;
      for (const auto& kv : b.lists) {
        const std::size_t n = kv.second.size();
        combos = combos > kMaxSweepPoints / n ? kMaxSweepPoints + 1 : combos * n;
        sizes += (sizes.empty() ? "" : " x ") + std::to_string(n);
      }
      total = std::min(total + combos, kMaxSweepPoints + 1);
      if (combos > kMaxSweepPoints)
        throw InputError(path + ": " + b.label + ": " + sizes + " values give more than " +
                         std::to_string(kMaxSweepPoints) + " points, the most a sweep holds (split the study into "
                         "several sweep files)");
      if (total > kMaxSweepPoints)
        throw InputError(path + ": " + b.label + ": the blocks up to this one give more than " +
                         std::to_string(kMaxSweepPoints) + " points, the most a sweep holds (split the study into "
                         "several sweep files)");
    }
  }

  // Name parts: the last part of each key, unless two keys of the sweep share it.
  std::map<std::string, std::set<std::string>> keys_of_part;
  for (const Block& b : blocks)
    for (const auto& kv : b.lists) keys_of_part[last_part(kv.first)].insert(kv.first);
  auto part_name = [&](const std::string& key) {
    std::string p = keys_of_part[last_part(key)].size() > 1 ? key : last_part(key);
    for (char& c : p)
      if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '+' || c == '-')) c = '.';
    return p;
  };

  std::map<std::string, std::size_t> by_name, by_identity;
  for (const Block& b : blocks) {
    std::size_t combos = 1;
    for (const auto& kv : b.lists) combos *= kv.second.size();
    for (std::size_t c = 0; c < combos; ++c) {
      SweepPoint p;
      p.index = s.points.size();
      p.base = b.base;
      p.block = b.label;
      p.overrides = common;
      std::size_t rest = c;
      std::vector<std::size_t> pick(b.lists.size());
      for (std::size_t j = b.lists.size(); j-- > 0;) {  // the last key varies fastest
        pick[j] = rest % b.lists[j].second.size();
        rest /= b.lists[j].second.size();
      }
      std::string name;
      for (std::size_t j = 0; j < b.lists.size(); ++j) {
        const toml::node& v = *b.lists[j].second[pick[j]];
        const std::string key = b.lists[j].first;
        p.params.emplace_back(key, toml_text(v));
        p.overrides.push_back({key, toml_text(v), path + ": " + b.label + " " + key});
        name += (name.empty() ? "" : "__") + part_name(key) + "-" + name_text(v);
      }
      if (name.empty()) name = "base";
      if (b.base != blocks.front().base) {
        std::string stem = b.base.stem().string();
        for (char& ch : stem)
          if (!name_char(ch)) ch = '.';
        if (stem.empty() || stem == "." || stem == "..") stem = "base";
        name = stem + (name == "base" ? "" : "__" + name);
      }
      // Every name is one path component below the root ('/' and control characters became '.' above).
      if (name == "." || name == "..") name = "p" + std::to_string(p.index);
      if (name.size() > 180) name = name.substr(0, 160) + "__p" + std::to_string(p.index);
      std::string identity = b.base.lexically_normal().string();
      for (const auto& kv : p.params) identity += "\n" + kv.first + "=" + kv.second;
      if (auto it = by_identity.find(identity); it != by_identity.end())
        throw InputError(path + ": " + b.label + " repeats point " + std::to_string(it->second) +
                         " (the same base and values)");
      by_identity[identity] = p.index;
      if (by_name.count(name)) name += "__p" + std::to_string(p.index);
      by_name[name] = p.index;
      p.name = name;
      s.points.push_back(std::move(p));
    }
  }
  return s;
}

Config point_config(const Sweep& sweep, const SweepPoint& p) {
  const std::string text = read_text(p.base, "base configuration");
  Config c = resolve_config(text, p.base.string(), p.overrides);
  c.source = sweep.file.string() + " point " + std::to_string(p.index) + " (" + p.base.string() + ")";
  validate_run_config(c);
  return c;
}

PointPaths point_paths(const Sweep& sweep, const SweepPoint& p) {
  PointPaths q;
  q.dir = sweep.root / p.name;
  q.config = q.dir / "config.toml";
  const RunPaths r = run_paths((q.dir / "output.h5").string());
  q.output = r.h5;
  q.checkpoint = r.checkpoint;
  q.lock = r.lock;
  q.log = q.dir / "run.log";
  q.result = q.dir / "result";
  return q;
}

const char* point_state_name(PointState s) {
  switch (s) {
    case PointState::Pending: return "pending";
    case PointState::Running: return "running";
    case PointState::Done: return "done";
    case PointState::Failed: return "failed";
    case PointState::Interrupted: return "interrupted";
    case PointState::Killed: return "killed";
    case PointState::Extendable: return "extendable";
  }
  return "?";
}

PointStatus inspect_point(const fs::path& dir, double end) {
  PointStatus st;
  st.end = end;
  const RunPaths r = run_paths((dir / "output.h5").string());
  std::error_code ec;
  st.has_checkpoint = fs::exists(r.checkpoint, ec);
  if (const std::optional<RunMarker> m = read_run_marker(r.lock)) {
    st.strain = m->strain;
    st.updated = m->heartbeat;
    st.message = describe_marker(*m);
    if (marker_owner(*m) == MarkerOwner::Live) {
      st.state = PointState::Running;
      return st;
    }
    // A marker left behind: the process died without its clean end; a newer result (the same task noted an
    // error) tells more.
    const std::optional<SweepResult> res = read_sweep_result(dir / "result");
    if (!res || res->finished < m->heartbeat) {
      st.state = PointState::Killed;
      st.message = "killed: " + st.message;
      return st;
    }
  }
  if (const std::optional<SweepResult> res = read_sweep_result(dir / "result")) {
    st.strain = res->strain;
    st.updated = res->finished;
    st.message = res->message;
    if (res->exit_code == 0 && res->end + 1e-9 >= end) {
      st.state = PointState::Done;
    } else if (res->exit_code == 0) {
      // A run that reached an earlier end is not done once [time] end grows; it was not interrupted either.
      st.state = PointState::Extendable;
      st.message = "reached its earlier [time] end, strain " + fmt(res->end) + "; continues to " + fmt(end) +
                   " from its checkpoint";
    } else if (is_interrupt(res->exit_code))
      st.state = PointState::Interrupted;
    else
      st.state = PointState::Failed;
    return st;
  }
  st.state = st.has_checkpoint ? PointState::Interrupted : PointState::Pending;
  if (st.has_checkpoint) {
    // No result beside the checkpoint (a run copied to another machine, or one whose process ended before writing
    // it): the checkpoint's own strain says how far the point got. A damaged checkpoint is reported by the run that
    // continues from it; here it only leaves the strain unknown.
    try {
      st.strain = read_checkpoint(r.checkpoint).state.time;
      if (*st.strain + 1e-9 >= end) {
        // Only a run that reached [time] end checkpoints past it: done (continuing it would be refused, --end
        // below the checkpoint's strain).
        st.state = PointState::Done;
        st.message = "reached strain " + fmt(*st.strain) + " (its checkpoint; no result file beside it)";
      } else {
        st.message = "continues from its checkpoint at strain " + fmt(*st.strain);
      }
    } catch (const std::exception&) {
      st.message = "continues from its checkpoint (its strain could not be read)";
    }
  }
  return st;
}

// ---------------------------------------------------------------------------------------------------------------
// The estimate of --plan: the configuration's cost estimator (run_estimate.hpp, the one `capsflow run --dry-run`
// prints: a fresh placement's rate for the first strain units, a developed suspension's after), and the disk the
// output and checkpoint take at [time] end (run_layout.hpp's datasets: per record, per frame, the state).
RunEstimate estimate_run(const Config& c, int threads) {
  RunEstimate e;
  const RunSize size = run_size(c);
  const CostEstimate cost = estimate_cost(c, size, std::max(1, threads));
  // The mean rate over the whole run, as the time is estimated: the fresh placement's for the first 2 strain units,
  // the developed suspension's after (the column of steps and the column of time then tell the same story).
  const double end_strain = c.time.end.value_or(0.0), fresh = std::min(end_strain, 2.0);
  e.steps_per_strain = end_strain > 0.0 ? (cost.steps_per_strain_start * fresh +
                                           cost.steps_per_strain_developed * (end_strain - fresh)) / end_strain
                                        : cost.steps_per_strain_developed;
  e.seconds_per_step = cost.seconds_per_step;
  e.seconds = cost.total_seconds;
  const double end = c.time.end.value_or(0.0);
  const double np = static_cast<double>(size.capsules), nn = static_cast<double>(size.nodes);
  const double ns = static_cast<double>(c.species.size());
  const double record = 8.0 * (6.0 + np * 12.0 + ns * c.output.profile_bins);
  const double frame = 8.0 * (1.0 + 6.0 * nn);
  const double checkpoint = 8.0 * 12.0 * nn;
  e.disk_bytes = end / c.output.every * record + end / c.output.frames_every * frame + checkpoint;
  return e;
}

// ---------------------------------------------------------------------------------------------------------------
// The verbs

namespace {

struct Resolved {
  const SweepPoint* point;
  Config config;
  PointPaths paths;
};

std::vector<Resolved> resolve_all(const Sweep& s) {
  std::vector<Resolved> out;
  for (const SweepPoint& p : s.points) out.push_back({&p, point_config(s, p), point_paths(s, p)});
  // One step rule per sweep: the rules take different numbers of steps to the same strain, so a sweep that mixed
  // them would mix two numerical protocols in one study (compare rules with two sweep files).
  for (const Resolved& r : out)
    if (r.config.time.step_rule != out.front().config.time.step_rule)
      throw InputError(s.file.string() + ": point " + std::to_string(r.point->index) + " uses [time] step_rule = \"" +
                       step_rule_name(r.config.time.step_rule) + "\" but point " +
                       std::to_string(out.front().point->index) + " uses \"" +
                       step_rule_name(out.front().config.time.step_rule) +
                       "\": one rule per sweep (compare the rules with two sweep files)");
  return out;
}

// Refuses a directory that holds another point (before anything is written). A point stored by a build before a
// default changed continues with the rules it ran with (keep_earlier_build_rules): the step rule must then be asked
// for by the sweep (one rule per sweep); the element rules of a point asked for at the defaults are the stored
// point's (its config.toml then names them), other rules are refused.
void check_stored_configs(std::vector<Resolved>& rs) {
  for (Resolved& r : rs) {
    std::error_code ec;
    if (!fs::exists(r.paths.config, ec)) continue;
    const std::string have_text = read_text(r.paths.config, "stored configuration");
    std::string have;
    try {
      Config stored = parse_config(have_text, r.paths.config.string());
      keep_earlier_build_rules(toml::parse(have_text), stored);
      if (r.config.quadrature == QuadratureOptions{}) r.config.quadrature = stored.quadrature;
      have = to_toml(normalized(stored));
    } catch (const InputError& e) {
      throw InputError(r.paths.config.string() + ": not a configuration this build reads (" + e.what() +
                       "); move the directory away");
    }
    const std::string want = to_toml(normalized(r.config));
    if (have != want)
      throw InputError(r.paths.config.string() + ": holds another configuration than point " +
                       std::to_string(r.point->index) + " of the sweep (" + first_difference(want, have) +
                       "); move the directory away, or restore the sweep file");
  }
}

// config.toml of a point, written once (refreshed when a run-control key such as [time] end changed).
void store_config(const Resolved& r) {
  fs::create_directories(r.paths.dir);
  Config c = r.config;
  c.output.file = r.paths.output.string();
  const std::string text = to_toml(c);
  std::error_code ec;
  if (fs::exists(r.paths.config, ec) && read_text(r.paths.config, "stored configuration") == text) return;
  write_file_atomically(r.paths.config, text);
}

// The Slurm time limit --plan suggests and --slurm uses without --time: the longest run x 1.3 + 10 min, at most two
// days (a task that reaches its limit checkpoints and requeues itself); and the signal's lead: time for the step in
// progress and the checkpoint, three of the longest estimated steps, at least 120 s.
struct SlurmSizing {
  double limit_seconds = 0.0;
  int signal_seconds = 120;
};
SlurmSizing slurm_sizing(const std::vector<Resolved>& rs, int threads) {
  double longest = 0, step_max = 0;
  for (const Resolved& r : rs) {
    const RunEstimate e = estimate_run(r.config, threads);
    longest = std::max(longest, e.seconds);
    step_max = std::max(step_max, e.seconds_per_step);
  }
  SlurmSizing z;
  z.limit_seconds = std::min(longest * 1.3 + 600.0, 2.0 * 86400);
  z.signal_seconds = static_cast<int>(std::ceil(std::max(120.0, 3.0 * step_max)));
  return z;
}

int print_plan(const Sweep& s, const std::vector<Resolved>& rs, int threads, std::ostream& out) {
  out << "capsflow sweep " << s.file.string() << ": " << rs.size() << " run(s) below " << s.root.string()
      << " (step rule " << (rs.empty() ? "-" : step_rule_name(rs.front().config.time.step_rule)) << ")\n";
  out << "  " << "#    " << "end      " << "est. steps  " << "est. time   " << "disk      " << "state         "
      << "directory\n";
  double total_s = 0, total_b = 0;
  for (const Resolved& r : rs) {
    const RunEstimate e = estimate_run(r.config, threads);
    const PointStatus st = inspect_point(r.paths.dir, *r.config.time.end);
    total_s += e.seconds;
    total_b += e.disk_bytes;
    char line[256];
    std::snprintf(line, sizeof line, "  %-4zu %-8s %-11.3g %-11s %-9s %-13s ", r.point->index,
                  fmt(*r.config.time.end).c_str(), e.steps_per_strain * *r.config.time.end,
                  human_time(e.seconds).c_str(), human_bytes(e.disk_bytes).c_str(), point_state_name(st.state));
    out << line << r.paths.dir.string() << "\n";
  }
  out << "  total: " << human_time(total_s) << " of runs at " << threads << " thread(s) each (estimate), "
      << human_bytes(total_b) << " of disk\n";
  const SlurmSizing z = slurm_sizing(rs, threads);
  out << "  suggested Slurm time limit per task: " << hms(z.limit_seconds) << ", signal " << z.signal_seconds
      << " s before it (longest run x 1.3 + 10 min, at most 2 days: a task that reaches its limit checkpoints and requeues "
         "itself)\n";
  out << "  estimate: capsflow run --dry-run's (docs/performance.md section 5), steps and time alike: a fresh "
         "placement's step rate for the first 2 strain units, a developed suspension's after (the same under step_rule "
         "membrane, 3-6x more steps under \"paper\"); --threads T sizes it\n";
  return 0;
}

int print_status(const Sweep& s, const std::vector<Resolved>& rs, std::ostream& out) {
  std::map<PointState, int> count;
  out << "capsflow sweep " << s.file.string() << ": " << rs.size() << " run(s) below " << s.root.string()
      << " (step rule " << (rs.empty() ? "-" : step_rule_name(rs.front().config.time.step_rule)) << ")\n";
  for (const Resolved& r : rs) {
    const PointStatus st = inspect_point(r.paths.dir, *r.config.time.end);
    ++count[st.state];
    char line[256];
    std::snprintf(line, sizeof line, "  %-4zu %-12s strain %-9s / %-7s %-21s ", r.point->index,
                  point_state_name(st.state), st.strain ? fmt(*st.strain).c_str() : "-",
                  fmt(st.end).c_str(), st.updated ? when(*st.updated).c_str() : "-");
    out << line << r.point->name;
    if (st.state != PointState::Pending && st.state != PointState::Done)
      out << "\n       " << st.message;
    out << "\n";
  }
  out << "  ";
  bool first = true;
  for (const auto& [state, n] : count) {
    out << (first ? "" : ", ") << n << " " << point_state_name(state);
    first = false;
  }
  out << "\n";
  return 0;
}

// What `--task I` passes to the run of a point in state `st` (and what --local checks for its children).
RunSettings task_settings(const SweepOptions& o, const Resolved& r, const PointStatus& st) {
  RunSettings settings;
  settings.output = r.paths.output.string();
  settings.end = *r.config.time.end;
  settings.progress_seconds = 60.0;
  if (o.backend) settings.backend = *o.backend;
  if (o.threads > 1 && !o.backend) settings.backend = std::string("threads");
  if (o.threads > 0) settings.threads = o.threads;
  if (st.has_checkpoint) {
    settings.restart = r.paths.checkpoint.string();
  } else {
    // No checkpoint: whatever an earlier attempt left (a failed retry, a start killed before its first
    // checkpoint) holds nothing to keep.
    settings.force = true;
  }
  return settings;
}

// Every check of the point's run that can refuse it, before the point's directory is touched (so that a refusal,
// exit 2, leaves no config.toml, run.log or result behind): the files' kinds (a link or a device is never written
// through), the output a continuation needs, and everything capsflow run --dry-run checks (the overrides, --threads
// and --backend, the checkpoint and its strain against [time] end, the memory the grid needs).
void precheck_task(const Resolved& r, const RunSettings& settings) {
  const RunPaths rp = run_paths(r.paths.output.string());
  for (const fs::path& p :
       {r.paths.config, r.paths.log, r.paths.result, rp.h5, rp.xdmf, rp.checkpoint, rp.lock})
    check_output_kind(p);
  std::error_code ec;
  if (!settings.restart.empty() && !fs::exists(rp.h5, ec))
    throw InputError(rp.h5.string() + ": missing, but " + rp.checkpoint.string() + " continues it: restore the "
                     "output, or move the checkpoint away to start the point again");
  // dry_run's warnings (more threads than CPUs) are the run's to print, once: silenced here.
  struct Silence {
    std::streambuf* old;
    ~Silence() { std::cerr.rdbuf(old); }  // rdbuf() also clears the state the dropped writes set
  } silence{std::cerr.rdbuf(nullptr)};
  std::ostream sink(nullptr);
  dry_run(r.config, settings, sink);
}

std::string shell_quote(const std::string& s);  // below, with the Slurm script

// --task I: one point, in this process.
int run_task(const SweepOptions& o, const Sweep& s, const std::vector<Resolved>& rs, std::ostream& out) {
  if (o.task < 0 || static_cast<std::size_t>(o.task) >= rs.size())
    throw InputError("--task " + std::to_string(o.task) + ": expected a point index from 0 to " +
                     std::to_string(rs.size() - 1) + " (" + s.file.string() + ")");
  const Resolved& r = rs[static_cast<std::size_t>(o.task)];
  const double end = *r.config.time.end;
  const PointStatus st = inspect_point(r.paths.dir, end);
  const std::string tag = "capsflow sweep: point " + std::to_string(o.task) + " (" + r.paths.dir.string() + "): ";
  if (st.state == PointState::Done) {
    out << tag << "done (strain " << fmt(st.strain.value_or(end)) << "), nothing to do\n";
    return 0;
  }
  if (st.state == PointState::Running) throw InputError(tag + "already running: " + st.message);
  if (st.state == PointState::Failed && !o.retry_failed) {
    out << tag << "failed earlier: " << st.message << " (rerun with --retry-failed)\n";
    return 3;
  }
  const RunSettings settings = task_settings(o, r, st);
  precheck_task(r, settings);  // every refusal before the first file of the point
  store_config(r);
  std::error_code ec;
  fs::remove(r.paths.result, ec);
  std::ofstream log(r.paths.log, std::ios::app);
  log << "== capsflow sweep " << s.file.string() << " --task " << o.task << " on " << this_host() << " at "
      << when(epoch_seconds()) << (settings.restart.empty() ? ": start" : ": continue from checkpoint") << " ("
      << build_description() << ")\n";
  log.flush();

  install_stop_signal_handlers();
  // SIGUSR1: Slurm's warning before the time limit (#SBATCH --signal=B:USR1@S): checkpoint like SIGTERM.
  struct sigaction sa {};
  sa.sa_handler = [](int sig) { request_stop(sig); };
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESETHAND;
  sigaction(SIGUSR1, &sa, nullptr);

  SweepResult res;
  res.end = end;
  RunResult rr;
  try {
    rr = run_simulation(r.config, settings, log);
  } catch (const std::exception& e) {
    res.exit_code = dynamic_cast<const InputError*>(&e) ? 2 : 1;
    res.message = e.what();
    res.strain = st.strain.value_or(0.0);
    res.finished = epoch_seconds();
    write_sweep_result(r.paths.result, res);
    log << "capsflow: error: " << one_line(e.what()) << "\n";
    throw;
  }
  res.exit_code = rr.exit_code;
  res.message = rr.stop_message.empty() ? "reached strain " + fmt(rr.time) : rr.stop_message;
  // An interrupted task continues as a task, not as a bare run: under Slurm by resubmitting its array index (the
  // script the --slurm verb wrote), elsewhere by `sweep --task` or `--local` (which also keep its result file).
  const std::string bare = "; continue with: capsflow run --restart";
  if (const std::size_t at = res.message.find(bare); at != std::string::npos) {
    const std::string script = (fs::absolute(s.root / "slurm") / (s.name + ".sbatch")).lexically_normal().string();
    const bool array = std::getenv("SLURM_ARRAY_JOB_ID") != nullptr;
    res.message = res.message.substr(0, at) + "; continue with: " +
                  (array ? "sbatch --array=" + std::to_string(o.task) + " " + shell_quote(script)
                         : "capsflow sweep " + shell_quote(s.file.string()) + " --task " + std::to_string(o.task) +
                               " (or --local)");
  }
  res.strain = rr.time;
  const char* job = std::getenv("SLURM_JOB_ID");
  const bool requeue = o.requeue && rr.exit_code == 128 + SIGUSR1 && job;
  if (requeue)
    res.message = "time limit near at strain " + fmt(rr.time) + ": checkpointed and requeued (scontrol requeue " +
                  job + "); continues from the checkpoint when Slurm starts it again";
  res.finished = epoch_seconds();
  write_sweep_result(r.paths.result, res);
  out << tag << (rr.exit_code == 0 ? "done: " : rr.exit_code == 3 ? "failed: " : "") << res.message << "\n";
  if (requeue) {
    // The time limit is near: the checkpoint is written; put this task back in the queue to continue.
    const std::string cmd = std::string("scontrol requeue ") + job;
    out << tag << "time limit near: " << cmd << "\n";
    out.flush();
    if (std::system(cmd.c_str()) != 0) {
      out << tag << "scontrol requeue failed; resubmit the task\n";
      res.message = "time limit near at strain " + fmt(rr.time) + ": checkpointed; scontrol requeue failed: resubmit "
                    "the task";
      write_sweep_result(r.paths.result, res);
    }
  }
  return rr.exit_code;
}

// --local: children `capsflow sweep FILE --task I`, N at a time.
volatile std::sig_atomic_t g_local_signal = 0;
extern "C" void capsflow_sweep_local_handler(int sig) { g_local_signal = sig; }

int run_local(const SweepOptions& o, const Sweep& s, const std::vector<Resolved>& rs, std::ostream& out) {
  if (o.jobs < 1) throw InputError("--jobs: expected an integer >= 1, got " + std::to_string(o.jobs));
  if (o.threads < 1) throw InputError("--threads: expected an integer >= 1, got " + std::to_string(o.threads));
  std::vector<std::size_t> todo;
  for (const Resolved& r : rs) {
    const PointStatus st = inspect_point(r.paths.dir, *r.config.time.end);
    const std::string tag = "  " + std::to_string(r.point->index) + " " + r.point->name + ": ";
    switch (st.state) {
      case PointState::Done: out << tag << "done, skipped\n"; break;
      case PointState::Running: out << tag << "running elsewhere, skipped (" << st.message << ")\n"; break;
      case PointState::Failed:
        if (o.retry_failed) {
          todo.push_back(r.point->index);
        } else {
          out << tag << "failed, skipped (--retry-failed): " << st.message << "\n";
        }
        break;
      default: todo.push_back(r.point->index);
    }
  }
  // Every run's refusals before the first file of any (a bad --threads, a damaged checkpoint): exit 2, nothing
  // written, rather than one failed point after another.
  for (std::size_t i : todo)
    precheck_task(rs[i], task_settings(o, rs[i], inspect_point(rs[i].paths.dir, *rs[i].config.time.end)));
  for (std::size_t i : todo) store_config(rs[i]);
  out << "capsflow sweep: " << todo.size() << " run(s) to do, " << o.jobs << " at a time, " << o.threads
      << " thread(s) each\n";
  out.flush();

  struct sigaction sa {};
  sa.sa_handler = capsflow_sweep_local_handler;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  std::map<pid_t, std::size_t> active;
  std::map<std::size_t, int> codes;
  std::size_t next = 0;
  int forwarded = 0;
  while ((g_local_signal == 0 && next < todo.size()) || !active.empty()) {
    if (g_local_signal != 0 && forwarded == 0) {
      // Each run checkpoints and stops; the children have their own process group, so this is their only signal.
      forwarded = g_local_signal;
      for (const auto& [pid, i] : active) ::kill(pid, forwarded);
    }
    while (g_local_signal == 0 && next < todo.size() && active.size() < static_cast<std::size_t>(o.jobs)) {
      const std::size_t i = todo[next++];
      const PointPaths& pp = rs[i].paths;
      std::vector<std::string> args = {o.executable, "sweep", s.file.string(), "--task", std::to_string(i),
                                       "--threads", std::to_string(o.threads)};
      if (o.backend) args.insert(args.end(), {"--backend", *o.backend});
      if (o.retry_failed) args.push_back("--retry-failed");
      std::vector<char*> argv;
      for (std::string& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      const pid_t pid = ::fork();
      if (pid < 0) throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
      if (pid == 0) {
        ::setpgid(0, 0);
        const int fd = ::open(pp.log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
        if (fd >= 0) {
          ::dup2(fd, 1);
          ::dup2(fd, 2);
        }
        ::execv(argv[0], argv.data());
        ::_exit(127);
      }
      active[pid] = i;
      out << "  started " << i << " " << rs[i].point->name << " (pid " << pid << ")\n";
      out.flush();
    }
    int status = 0;
    const pid_t done = active.empty() ? 0 : ::waitpid(-1, &status, WNOHANG);
    if (done == 0) ::usleep(100000);  // polled, so that a signal is forwarded at once
    if (done > 0 && active.count(done)) {
      const std::size_t i = active[done];
      active.erase(done);
      const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      codes[i] = code;
      const PointStatus st = inspect_point(rs[i].paths.dir, *rs[i].config.time.end);
      out << "  finished " << i << " " << rs[i].point->name << ": " << point_state_name(st.state) << " (exit "
          << code << ")" << (st.state == PointState::Done ? "" : ": " + st.message) << "\n";
      out.flush();
    } else if (done < 0 && errno != EINTR && errno != ECHILD) {
      throw std::runtime_error(std::string("waitpid: ") + std::strerror(errno));
    }
  }
  signal(SIGINT, SIG_DFL);
  signal(SIGTERM, SIG_DFL);
  if (forwarded) {
    out << "capsflow sweep: interrupted; the runs checkpointed: rerun the same command to continue\n";
    return 128 + forwarded;
  }
  // The exit status tells whether the whole sweep is done (so that `sweep --local && analyze` analyses finished
  // runs only): 0 every point done; 3 while any point is failed (run now or earlier); 4 while any other is not done
  // (running elsewhere, or interrupted or killed there).
  std::map<PointState, int> count;
  for (const Resolved& r : rs) ++count[inspect_point(r.paths.dir, *r.config.time.end).state];
  const int not_done = static_cast<int>(rs.size()) - count[PointState::Done] - count[PointState::Failed];
  out << "capsflow sweep: " << codes.size() << " run(s) ran; now " << count[PointState::Done] << " of " << rs.size()
      << " done, " << count[PointState::Failed] << " failed";
  if (not_done > 0) {
    out << ", " << not_done << " not done (";
    bool first = true;
    for (PointState ps : {PointState::Running, PointState::Interrupted, PointState::Killed, PointState::Extendable,
                          PointState::Pending})
      if (count[ps] > 0) {
        out << (first ? "" : ", ") << count[ps] << " " << point_state_name(ps);
        first = false;
      }
    out << ")";
  }
  out << " (capsflow sweep " << s.file.string() << " --status)\n";
  if (count[PointState::Failed]) return 3;
  if (not_done > 0) {
    out << "capsflow sweep: not every point is done (exit " << kSweepExitNotDone << "): "
        << (count[PointState::Running] ? "wait for the runs elsewhere, then " : "") << "rerun to continue\n";
    return kSweepExitNotDone;
  }
  return 0;
}

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

bool valid_time_limit(const std::string& t) {
  // Slurm's forms: MM, MM:SS, HH:MM:SS, D-HH, D-HH:MM, D-HH:MM:SS.
  if (t.empty()) return false;
  for (char c : t)
    if (!(std::isdigit(static_cast<unsigned char>(c)) || c == ':' || c == '-')) return false;
  return std::count(t.begin(), t.end(), '-') <= 1 && std::count(t.begin(), t.end(), ':') <= 2;
}

bool token_of(const std::string& v, const char* extra_chars) {
  return !v.empty() && std::all_of(v.begin(), v.end(), [&](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || std::strchr(extra_chars, c) != nullptr;
  });
}

bool valid_mem(const std::string& m) {
  // sbatch --mem=<size>[units]: digits, then at most one unit letter (K, M, G, T; MB without one).
  std::size_t digits = 0;
  while (digits < m.size() && std::isdigit(static_cast<unsigned char>(m[digits]))) ++digits;
  if (digits == 0 || digits > 18) return false;
  return digits == m.size() || (digits + 1 == m.size() && std::strchr("KMGTkmgt", m.back()) != nullptr);
}

// Every value that --slurm puts into the script, checked before anything is written: each #SBATCH value is a token
// of a fixed character set (sbatch reads one directive per line, and stops at the first line that is not one, so
// a line break in a value would both run a command and drop the directives after it); paths on the `exec` line are
// single-quoted and may hold anything but control characters (they appear in the comments too).
struct SlurmValues {
  std::string name, output_dir, exe, sweep_file, script;
};
SlurmValues checked_slurm_values(const SweepOptions& o, const Sweep& s) {
  SlurmValues v;
  const std::string file = s.file.string();
  if (!valid_job_name(s.name))
    throw InputError(file + ": name: the sweep file's stem '" + printable(s.name) + "' is not a Slurm job name " +
                     "(expected " + kNameRule + "): add name = \"...\" to the sweep file");
  v.name = s.name;
  if (!o.partition.empty() && !token_of(o.partition, "._+-,"))
    throw InputError("--partition: expected a partition name, or a comma-separated list of them, from A-Z a-z 0-9 "
                     ". _ + -, got '" + printable(o.partition) + "'");
  if (!o.account.empty() && !token_of(o.account, "._+-"))
    throw InputError("--account: expected an account name from A-Z a-z 0-9 . _ + -, got '" + printable(o.account) +
                     "'");
  if (!o.mem.empty() && !valid_mem(o.mem))
    throw InputError("--mem: expected a size such as 4000 (MB), 512M, 16G or 1T (digits, then at most one of K M G "
                     "T), got '" + printable(o.mem) + "'");
  if (!o.extra.empty() && (o.extra.front() != '-' || has_control(o.extra)))
    throw InputError("--sbatch-extra: expected sbatch options on one line, starting with '-' and without control "
                     "characters (e.g. '--qos=long'), got '" + printable(o.extra) + "'");
  if (o.backend && !token_of(*o.backend, "_-"))
    throw InputError("--backend: expected serial, threads or device, got '" + printable(*o.backend) + "'");
  v.output_dir = fs::absolute(s.root / "slurm").lexically_normal().string();
  for (char c : v.output_dir)
    if (std::isspace(static_cast<unsigned char>(c)) || c == '"' || c == '\'' || c == '\\' || c == '%' ||
        control_char(c))
      throw InputError(file + ": root: expected, for --slurm, a directory whose path has no whitespace, quotes, "
                       "backslashes, '%' or control characters (it goes into #SBATCH --output=), got '" +
                       printable(v.output_dir) + "'");
  v.exe = fs::absolute(o.executable).string();
  if (v.exe.empty() || has_control(v.exe))
    throw InputError("--slurm: the path of this capsflow executable holds a control character ('" + printable(v.exe) +
                     "'): install it under another path");
  v.sweep_file = fs::absolute(s.file).lexically_normal().string();
  if (has_control(v.sweep_file))
    throw InputError(file + ": the sweep file's path holds a control character ('" + printable(v.sweep_file) +
                     "'): rename it for --slurm");
  v.script = (fs::path(v.output_dir) / (v.name + ".sbatch")).string();
  return v;
}

int write_slurm(const SweepOptions& o, const Sweep& s, const std::vector<Resolved>& rs, std::ostream& out) {
  if (o.cpus_per_task < 1) throw InputError("--cpus-per-task: expected an integer >= 1");
  if (o.gpus_per_task < 0) throw InputError("--gpus-per-task: expected an integer >= 0");
  // Every task would run --backend device and be refused at its start, on the cluster, after waiting in the queue.
  if (o.gpus_per_task > 0 && !device_backend_built())
    throw InputError("--gpus-per-task " + std::to_string(o.gpus_per_task) + ": expected 0 with this capsflow, "
                     "which was built without the device backend (CAPSFLOW_OFFLOAD=ON; docs/device.md): its tasks "
                     "could not use a GPU");
  if (o.max_parallel < 0) throw InputError("--max-parallel: expected an integer >= 0 (0: no limit)");
  // Slurm takes the signal's lead as a 16-bit number of seconds.
  if (o.signal_seconds < 0 || o.signal_seconds > 65535)
    throw InputError("--signal-seconds: expected an integer from 0 to 65535, got " + std::to_string(o.signal_seconds));
  const SlurmSizing z = slurm_sizing(rs, o.cpus_per_task);
  std::string limit = o.time_limit;
  if (limit.empty()) limit = hms(z.limit_seconds);
  if (!valid_time_limit(limit))
    throw InputError("--time: expected a Slurm time limit such as 12:00:00 or 2-00:00:00, got '" + printable(limit) +
                     "'");
  const SlurmValues v = checked_slurm_values(o, s);
  const int warn = o.signal_seconds > 0 ? o.signal_seconds : z.signal_seconds;
  const fs::path dir = v.output_dir;
  const fs::path script = v.script;
  // Refused before the directory is made: a script path that exists as something else than a regular file.
  check_output_kind(script);
  fs::create_directories(dir);
  const std::string& exe = v.exe;
  const std::string& sweep_file = v.sweep_file;
  std::ostringstream sh;
  sh << "#!/bin/bash\n"
     << "# capsflow sweep " << shell_quote(sweep_file) << ": " << rs.size() << " run(s), one array task per run "
     << "(written by capsflow sweep --slurm; docs/sweeps.md).\n"
     << "# Submit: sbatch " << shell_quote(v.script) << "   (one task again: sbatch --array=I "
     << shell_quote(v.script) << ")\n"
     << "#SBATCH --job-name=" << v.name << "\n"
     << "#SBATCH --array=0-" << rs.size() - 1 << (o.max_parallel > 0 ? "%" + std::to_string(o.max_parallel) : "")
     << "\n"
     << "#SBATCH --output=" << v.output_dir << "/%A_%a.out\n"
     << "#SBATCH --open-mode=append\n"
     << "#SBATCH --time=" << limit << "\n"
     << "#SBATCH --ntasks=1\n"
     << "#SBATCH --cpus-per-task=" << o.cpus_per_task << "\n";
  if (o.gpus_per_task > 0) sh << "#SBATCH --gpus-per-task=" << o.gpus_per_task << "\n";
  if (!o.partition.empty()) sh << "#SBATCH --partition=" << o.partition << "\n";
  if (!o.account.empty()) sh << "#SBATCH --account=" << o.account << "\n";
  if (!o.mem.empty()) sh << "#SBATCH --mem=" << o.mem << "\n";
  if (!o.extra.empty()) sh << "#SBATCH " << o.extra << "\n";
  sh << "# A preempted or failed node's task goes back to the queue and continues from its checkpoint.\n"
     << "#SBATCH --requeue\n"
     << "# SIGUSR1 " << warn << " s before the time limit: the run checkpoints and the task requeues itself.\n"
     << "#SBATCH --signal=B:USR1@" << warn << "\n"
     << "export OMP_NUM_THREADS=${SLURM_CPUS_PER_TASK:-" << o.cpus_per_task << "}\n"
     << "exec " << shell_quote(exe) << " sweep " << shell_quote(sweep_file)
     << " --task \"$SLURM_ARRAY_TASK_ID\" --threads \"$OMP_NUM_THREADS\"";
  if (o.gpus_per_task > 0)
    sh << " --backend device";
  else if (o.backend)
    sh << " --backend " << shell_quote(*o.backend);
  if (o.retry_failed) sh << " --retry-failed";
  sh << " --requeue\n";
  write_file_atomically(script, sh.str());
  fs::permissions(script, fs::perms::owner_exec | fs::perms::group_exec, fs::perm_options::add);
  out << "capsflow sweep: wrote " << script.string() << " (" << rs.size() << " task(s), --time " << limit
      << ", " << o.cpus_per_task << " CPU(s)" << (o.gpus_per_task ? ", " + std::to_string(o.gpus_per_task) + " GPU(s)" : "")
      << " per task)\n";
  if (!o.submit) {
    out << "  submit with: sbatch " << script.string() << "\n";
    return 0;
  }
  const std::string cmd = "sbatch " + shell_quote(script.string());
  out << "  " << cmd << "\n";
  out.flush();
  const int rc = std::system(cmd.c_str());
  if (rc != 0) throw InputError("sbatch failed (exit " + std::to_string(WIFEXITED(rc) ? WEXITSTATUS(rc) : rc) + "): " + cmd);
  return 0;
}

}  // namespace

int run_sweep(const SweepOptions& o, std::ostream& out) {
  const Sweep s = load_sweep(o.file);
  std::vector<Resolved> rs = resolve_all(s);
  check_stored_configs(rs);
  switch (o.verb) {
    case SweepOptions::Verb::Plan: return print_plan(s, rs, o.threads, out);
    case SweepOptions::Verb::Status: return print_status(s, rs, out);
    case SweepOptions::Verb::Task: return run_task(o, s, rs, out);
    case SweepOptions::Verb::Local: return run_local(o, s, rs, out);
    case SweepOptions::Verb::Slurm: return write_slurm(o, s, rs, out);
  }
  return 1;
}

}  // namespace capsflow
