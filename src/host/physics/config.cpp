// The run configuration's document level (config.hpp; every key is listed in docs/usage.md): the TOML text parsed,
// overrides applied to it, every section read and checked, and Config's resolved values. The configuration has four
// rooms:
//   config_reader   SectionReader: typed access to one [section] and the words of its messages
//   config_schema   the sections and their keys (one reader function each), config_keys(), to_toml
//   config_checks   the checks across keys (check_run_sections, cross_check, validate_run_config)
//   config          this file: parse_config / resolve_config / load_config, overrides, Config's methods
#include "host/physics/config.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <toml++/toml.h>
#include <utility>
#include <vector>

#include "host/base/errors.hpp"
#include "host/physics/config_checks.hpp"
#include "host/physics/config_reader.hpp"
#include "host/physics/config_toml.hpp"
#include "kernels/element_quadrature.hpp"
#include "kernels/ggem_kernels.hpp"

namespace capsflow {

using namespace config_detail;

namespace {

// The section list as messages give it: "[domain], [ggem], ..., [[species]], ...".
std::string known_sections() {
  std::string known;
  for (const auto& s : config_sections())
    known += std::string(known.empty() ? "" : ", ") + (s.array ? "[[" : "[") + s.name + (s.array ? "]]" : "]");
  return known;
}

const SectionSpec* find_section(const std::string& name) {
  for (const auto& s : config_sections())
    if (name == s.name) return &s;
  return nullptr;
}

// The top-level entry `name` must be a table, or a non-empty array of tables for [[name]]. `where` prefixes the
// message: the file, or the override that reached for the section.
void check_section_shape(const SectionSpec& spec, const toml::node& v, const std::string& where) {
  const std::string name = spec.name;
  if (spec.array) {
    const toml::array* a = v.as_array();
    if (!a || a->empty() || !a->is_array_of_tables())
      throw InputError(where + ": [[" + name + "]]: expected an array of tables [[" + name + "]], got " + describe(v));
  } else if (!v.is_table()) {
    throw InputError(where + ": [" + name + "]: expected a table [" + name + "], got " + describe(v));
  }
}

[[noreturn]] void unknown_section(const std::string& where, const std::string& name, bool is_table) {
  throw InputError(where + ": expected one of the sections " + known_sections() + ", got unknown " +
                   (is_table ? "section" : "top-level key") + " '" + one_line(name) + "'");
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t"), e = s.find_last_not_of(" \t");
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

std::vector<std::string> split_key(const std::string& key) {
  std::vector<std::string> parts;
  std::string cur;
  for (char ch : key) {
    if (ch == '.') {
      parts.push_back(trim(cur));
      cur.clear();
    } else {
      cur += ch;
    }
  }
  parts.push_back(trim(cur));
  return parts;
}

// The value of an override as a TOML node: TOML value syntax, or a bare word (no quotes, brackets, braces, '=',
// '#', ',' or spaces) taken as a string, so that run.backend=threads works as well as run.backend="threads".
toml::table parse_override_value(const ConfigOverride& o) {
  const std::string expected = "expected a TOML value (a number, true or false, \"text\", [a, b]), got '" +
                               one_line(o.value) + "'";
  if (o.value.find_first_of("\n\r") != std::string::npos) throw InputError(o.origin + ": " + expected);
  try {
    toml::table t = toml::parse("v = " + o.value);
    if (t.size() == 1 && t.contains("v")) return t;
  } catch (const toml::parse_error&) {
  }
  if (!o.value.empty() && o.value.find_first_of("\"'[]{}=#, \t") == std::string::npos) {
    toml::table t;
    t.insert("v", o.value);
    return t;
  }
  throw InputError(o.origin + ": " + expected);
}

}  // namespace

ConfigOverride parse_override(const std::string& arg) {
  const auto eq = arg.find('=');
  const std::string key = eq == std::string::npos ? trim(arg) : trim(arg.substr(0, eq));
  if (eq == std::string::npos || key.empty())
    throw InputError("--set " + one_line(arg) + ": expected section.key=value (e.g. suspension.seed=3), got '" +
                     one_line(arg) + "'");
  return {key, trim(arg.substr(eq + 1)), "--set " + one_line(key)};
}

std::vector<ConfigOverride> parse_overrides(const std::vector<std::string>& args) {
  std::vector<ConfigOverride> out;
  for (const std::string& a : args) out.push_back(parse_override(a));
  return out;
}

AppliedOverrides apply_overrides(toml::table& root, const std::vector<ConfigOverride>& overrides,
                                 const std::string& source_name) {
  AppliedOverrides applied;
  for (const ConfigOverride& o : overrides) {
    const std::vector<std::string> path = split_key(o.key);
    if (path.size() < 2)
      throw InputError(o.origin + ": expected section.key=value (e.g. suspension.seed=3), got '" + one_line(o.key) +
                       "'");
    const SectionSpec* spec = find_section(path[0]);
    if (!spec) unknown_section(o.origin, path[0], true);
    const std::string name = spec->name;
    const std::size_t want = spec->array ? 3 : 2;
    bool empty_part = false;
    for (const auto& p : path) empty_part = empty_part || p.empty();
    if (path.size() != want || empty_part)
      throw InputError(o.origin + ": expected " +
                       (spec->array ? name + ".N.key or " + name + ".NAME.key (an entry of [[" + name + "]])"
                                    : name + ".key (a key of [" + name + "])") +
                       ", got '" + one_line(o.key) + "'");
    const toml::table value = parse_override_value(o);
    const std::string& key = path.back();

    toml::table* target = nullptr;
    std::string label;
    if (!spec->array) {
      toml::node* sec = root.get(name);
      if (!sec) sec = &root.insert_or_assign(name, toml::table{}).first->second;
      check_section_shape(*spec, *sec, source_name);
      target = sec->as_table();
      label = "[" + name + "] " + key;
    } else {
      toml::node* sec = root.get(name);
      if (!sec) sec = &root.insert_or_assign(name, toml::array{}).first->second;
      if (!(sec->is_array() && sec->as_array()->is_array_of_tables())) check_section_shape(*spec, *sec, source_name);
      toml::array& arr = *sec->as_array();
      const std::string& sel = path[1];
      std::size_t index = 0;  // from 1
      if (sel.find_first_not_of("0123456789") == std::string::npos) {
        index = sel.size() < 9 ? static_cast<std::size_t>(std::stoul(sel)) : 0;
      } else {
        for (std::size_t i = 0; i < arr.size(); ++i) {
          const toml::table* t = arr.get(i)->as_table();
          const toml::node* n = t ? t->get("name") : nullptr;
          if (n && n->as_string() && n->as_string()->get() == sel) index = i + 1;
        }
      }
      if (index < 1 || index > arr.size() + 1) {
        std::string names;
        for (std::size_t i = 0; i < arr.size(); ++i) {
          const toml::table* t = arr.get(i)->as_table();
          const toml::node* n = t ? t->get("name") : nullptr;
          if (n && n->as_string()) names += (names.empty() ? "\"" : ", \"") + one_line(n->as_string()->get()) + "\"";
        }
        throw InputError(o.origin + ": expected the number of a [[" + name + "]] entry (1 to " +
                         std::to_string(arr.size()) + ", or " + std::to_string(arr.size() + 1) + " to add one)" +
                         (names.empty() ? std::string() : " or the name of one (" + names + ")") + ", got '" +
                         one_line(sel) + "'");
      }
      if (index == arr.size() + 1) arr.push_back(toml::table{});
      target = arr.get(index - 1)->as_table();
      label = "[[" + name + "]] " + std::to_string(index) + " " + key;
    }
    value.get("v")->visit([&](const auto& n) { target->insert_or_assign(key, n); });
    applied.keys[{target, key}] = o.origin;
    applied.labels[label] = o.origin;
  }
  return applied;
}

Config read_config(const toml::table& root, const std::string& source_name, const AppliedOverrides& applied,
                   bool stored) {
  for (const auto& [k, v] : root) {
    const std::string name(k.str());
    const SectionSpec* spec = find_section(name);
    if (!spec) unknown_section(source_name + ": [" + one_line(name) + "]", name, v.is_table());
    check_section_shape(*spec, v, source_name);
  }

  Config c;
  c.source = source_name;
  c.origins = applied.labels;
  for (const auto& s : config_sections()) {
    if (s.array) {
      const toml::array* a = root[s.name].as_array();
      for (std::size_t i = 0; a && i < a->size(); ++i) {
        SectionReader r(a->get(i)->as_table(), s.name, source_name,
                        "[[" + std::string(s.name) + "]] " + std::to_string(i + 1), &applied.keys);
        r.set_stored(stored);
        s.read(r, c);
        r.finish();
      }
      continue;
    }
    SectionReader r(root[s.name].as_table(), s.name, source_name, "", &applied.keys);
    r.set_stored(stored);
    s.read(r, c);
    r.finish();
  }
  check_drop_inflation(c);
  cross_check(c);
  check_run_sections(c);
  return c;
}

Config resolve_config(const std::string& text, const std::string& source_name,
                      const std::vector<ConfigOverride>& overrides) {
  toml::table root;
  try {
    root = toml::parse(text, source_name);
  } catch (const toml::parse_error& e) {
    const auto& where = e.source().begin;
    throw InputError(source_name + ":" + std::to_string(where.line) + ":" + std::to_string(where.column) +
                     ": invalid TOML: " + one_line(std::string(e.description())));
  }
  const AppliedOverrides applied = apply_overrides(root, overrides, source_name);
  // capsflow's own resolved text (to_toml: a run's stored config) writes every key, defaults included.
  return read_config(root, source_name, applied, text.rfind(kResolvedHeader, 0) == 0);
}

Config parse_config(const std::string& text, const std::string& source_name,
                    const std::vector<std::string>& overrides) {
  return resolve_config(text, source_name, parse_overrides(overrides));
}

const char* step_rule_name(StepRule r) { return r == StepRule::Paper ? "paper" : "membrane"; }

std::string Config::origin(const std::string& label) const {
  auto it = origins.find(label);
  return it != origins.end() ? it->second : source + ": " + label;
}

namespace {
// Run control: how far, on what, and how often to write. Everything else is the physics (or the layout of the output
// file) that the checkpoint fixes.
constexpr const char* kRunControlKeys[] = {"time.end",     "time.stop_pair_dx",   "run.backend",
                                           "run.threads",  "output.every",        "output.frames_every",
                                           "output.checkpoint_every", "gmres.max_iterations",
                                           "gmres.restart",        "gmres.preconditioner"};
}  // namespace

bool is_run_control_key(const std::string& key) {
  std::string k;
  for (const std::string& p : split_key(key)) k += (k.empty() ? "" : ".") + p;
  for (const char* r : kRunControlKeys)
    if (k == r) return true;
  return false;
}

void check_restart_overrides(const std::vector<ConfigOverride>& overrides) {
  for (const ConfigOverride& o : overrides) {
    if (is_run_control_key(o.key)) continue;
    std::string keys;
    for (const char* r : kRunControlKeys) keys += std::string(keys.empty() ? "" : ", ") + r;
    throw InputError(o.origin + ": cannot change when continuing a run (--restart): the checkpoint fixes the "
                     "physics; only the run-control keys " + keys + " may change" +
                     (o.key == "output.file" ? " (--output names the output file)" : ""));
  }
}

void keep_earlier_build_rules(const toml::table& stored, Config& c) {
  if (!stored["time"]["step_rule"]) c.time.step_rule = StepRule::Paper;
  if (!stored["quadrature"]) c.quadrature = fine_quadrature();
}

QuadratureOptions fine_quadrature() {
  const QuadratureOrders k{};  // the kernels' own rules, so that this cannot drift from them
  QuadratureOptions q;
  q.singular = k.singular;
  q.far_ratio = k.far_ratio;
  q.symmetric_ratio = k.symmetric_ratio;
  q.mid_ratio = k.mid_ratio;
  q.regular_mid = k.regular_mid;
  q.regular_near = k.regular_near;
  q.near_ratio = k.near_ratio;
  q.near_points = k.near_angle;  // near_angle = near_radial in the kernels' rules
  q.kernel_degree = k.kernel_degree;
  return q;
}

double Config::species_radius(std::size_t i) const { return species[i].radius.value_or(capsules.radius); }

double Config::species_step_ca(std::size_t i) const {
  return species[i].ca * (capsules.radius / species_radius(i)) / step_stiffness_factor(species_membrane(i)) *
         step_viscosity_factor(species[i].viscosity_ratio);
}

bool Config::has_viscosity_contrast() const {
  for (const SpeciesSpec& s : species)
    if (s.viscosity_ratio != 1.0) return true;
  return false;
}

MembraneParameters Config::species_membrane(std::size_t i) const {
  const SpeciesSpec& sp = species[i];
  MembraneParameters m = capsules.membrane;
  if (sp.law) m.law = *sp.law;
  if (sp.skalak_c) m.skalak_C = *sp.skalak_c;
  if (sp.inflation) m.inflation = *sp.inflation;
  return m;
}

double Config::species_bounding_radius(std::size_t i) const {
  return shape_bounding_radius(species[i].shape, species_radius(i));
}

double Config::max_bounding_radius() const {
  double a = species.empty() ? capsules.radius : 0.0;
  for (std::size_t i = 0; i < species.size(); ++i) a = std::max(a, species_bounding_radius(i));
  return a;
}

double mean_capsule_volume(const Config& c) {
  const std::vector<double> f =
      c.suspension && c.suspension->fractions.size() == c.species.size() ? c.suspension->fractions
                                                                          : std::vector<double>(c.species.size(), 0.0);
  bool one_radius = true;
  for (std::size_t i = 1; i < c.species.size(); ++i)
    one_radius = one_radius && c.species_radius(i) == c.species_radius(0);
  if (one_radius) {
    const double a = c.species.empty() ? c.capsules.radius : c.species_radius(0);
    return 4.0 / 3.0 * kPi * a * a * a;  // the expression of the single-radius code: same bits
  }
  double v = 0.0;
  for (std::size_t i = 0; i < f.size(); ++i) {
    const double a = c.species_radius(i);
    v += f[i] * (4.0 / 3.0 * kPi * a * a * a);
  }
  return v;
}

int Config::species_index(const std::string& name) const {
  for (std::size_t i = 0; i < species.size(); ++i)
    if (species[i].name == name) return static_cast<int>(i);
  return -1;
}

Config load_config(const std::string& path, const std::vector<ConfigOverride>& overrides) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the config file: " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(path + ": cannot read the config file");
  return resolve_config(text.str(), path, overrides);
}

namespace {

// The shortest text that reads back to the same double (0.1, not 0.10000000000000001), kept a TOML float.
std::string toml_double(double v) {
  std::string s = fmt(v);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";  // keep it a TOML float
  return s;
}

std::string toml_string(const std::string& v) {
  std::string o = "\"";
  for (char ch : v) {
    if (ch == '"' || ch == '\\') {
      o += '\\';
      o += ch;
    } else if (static_cast<unsigned char>(ch) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(ch)));
      o += buf;
    } else {
      o += ch;
    }
  }
  return o + "\"";
}

}  // namespace

std::vector<ConfigOverride> run_flag_overrides(const std::optional<double>& end,
                                               const std::optional<std::string>& backend,
                                               const std::optional<int>& threads) {
  std::vector<ConfigOverride> o;
  if (end) o.push_back({"time.end", toml_double(*end), "--end"});
  if (backend) o.push_back({"run.backend", toml_string(*backend), "--backend"});
  if (threads) o.push_back({"run.threads", std::to_string(*threads), "--threads"});
  return o;
}

}  // namespace capsflow
