// Reading the run configuration (config.hpp; every key is listed in docs/usage.md).
//
// The parser is table-driven so that a new section costs one reader function and one row in kSections:
//
//   SectionReader r(root, "domain", source);     // a view of one [section]
//   geo.H = r.number("H", Req{}, positive);      // typed key: required, or with a default; a range check
//   r.finish();                                  // any key that no reader asked for is an error
//
// Every error is one line, "<file>: [section] key: expected <what>, got <what>", thrown as InputError, so the
// command line can print it as is. Integers are accepted where a number is expected (H = 4 means 4.0); a
// float where an integer is expected is an error rather than a silent truncation.
#include "host/physics/config.hpp"
#include "host/physics/config_toml.hpp"
#include "host/base/printable.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <optional>
#include <sstream>
#include <string_view>
#include <toml++/toml.h>
#include <utility>
#include <vector>

#include "host/base/backend_select.hpp"
#include "host/physics/config_schema.hpp"
#include "host/base/errors.hpp"
#include "kernels/ggem_kernels.hpp"

namespace capsflow {
namespace {

// Shortest text that reads back as the same double ("2", "0.1", "1e-09").
std::string fmt(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  std::array<char, 64> buf{};
  auto res = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  return std::string(buf.data(), res.ptr);
}

// One line: newlines inside a message (toml++ descriptions, user strings) would break the one-line contract.
std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

// How a TOML value is named after "got": its type, and the value itself where it is short.
std::string describe(const toml::node& n) {
  if (auto v = n.as_integer()) return "integer " + std::to_string(v->get());
  if (auto v = n.as_floating_point()) {
    std::string t = fmt(v->get());
    if (t.find_first_of(".eni") == std::string::npos) t += ".0";  // a float that looks like one: "16.0"
    return "float " + t;
  }
  if (auto v = n.as_boolean()) return std::string("boolean ") + (v->get() ? "true" : "false");
  if (auto v = n.as_string()) return "string \"" + one_line(v->get()) + "\"";
  if (n.is_array()) return "an array";
  if (n.is_table()) return "a table";
  if (n.is_date()) return "a date";
  if (n.is_time()) return "a time";
  if (n.is_date_time()) return "a date-time";
  return "an unsupported value";
}

// A range check: `ok` tells whether a value is accepted, `what` says what is expected ("> 0").
struct Range {
  std::function<bool(double)> ok;
  std::string what;
};
Range any_number() { return {[](double) { return true; }, ""}; }
Range positive() { return {[](double v) { return v > 0.0; }, "> 0"}; }
Range at_least(double lo) { return {[lo](double v) { return v >= lo; }, ">= " + fmt(lo)}; }
Range in_half_open(double lo, double hi) {  // lo < v <= hi
  return {[lo, hi](double v) { return v > lo && v <= hi; }, "in (" + fmt(lo) + ", " + fmt(hi) + "]"};
}
Range in_open(double lo, double hi) {  // lo < v < hi
  return {[lo, hi](double v) { return v > lo && v < hi; }, "in (" + fmt(lo) + ", " + fmt(hi) + ")"};
}
Range in_closed(double lo, double hi) {  // lo <= v <= hi
  return {[lo, hi](double v) { return v >= lo && v <= hi; }, "in [" + fmt(lo) + ", " + fmt(hi) + "]"};
}

// Set while config_keys() runs the readers: every typed accessor records its key here, and a required key that is
// absent takes a placeholder instead of throwing, so that the reader goes on to its later keys.
std::vector<ConfigKey>* g_schema = nullptr;

// The first line of to_toml's text (a run's stored config); resolve_config reads such text as capsflow's own.
constexpr const char* kResolvedHeader = "# Resolved configuration (every key, defaults filled in)";

// A view of one [section] of the document that hands out typed keys and remembers which it handed out.
class SectionReader {
 public:
  // `label` is how messages name the section: "[domain]" by default, "[[species]] 2" for an array element.
  // `origins`: the keys of this table that an override set, and how messages name them ("--set suspension.seed").
  SectionReader(const toml::table* table, std::string section, std::string source, std::string label = "",
                const OverrideOrigins* origins = nullptr)
      : table_(table),
        section_(std::move(section)),
        source_(std::move(source)),
        label_(label.empty() ? "[" + section_ + "]" : std::move(label)),
        origins_(origins) {}

  bool present() const { return table_ != nullptr; }

  // Whether the input wrote `key` (not its default). In capsflow's own resolved text (a run's stored config, where
  // every key is written) only an override counts: its keys' presence says nothing about what the user chose.
  bool given(std::string_view key) {
    if (!lookup(key)) return false;
    return !stored_ || (origins_ && origins_->count({table_, std::string(key)}) > 0);
  }
  void set_stored(bool stored) { stored_ = stored; }

  // A floating-point key (integers accepted). Absent: the default, or an error when it is required.
  double number(std::string_view key, std::optional<double> dflt, const Range& range = any_number()) {
    describe_key(key, "number", expect_number(range), !dflt, range.ok);
    auto v = optional_number(key, range);
    if (v) return *v;
    if (!dflt && g_schema) return 1.0;
    if (!dflt) missing(key, expect_number(range));
    return *dflt;
  }

  std::optional<double> optional_number(std::string_view key, const Range& range = any_number()) {
    describe_key(key, "number", expect_number(range), false, range.ok);
    const toml::node* n = lookup(key);
    if (!n) return std::nullopt;
    double v = 0.0;
    if (auto i = n->as_integer()) {
      v = static_cast<double>(i->get());
    } else if (auto f = n->as_floating_point()) {
      v = f->get();
    } else {
      fail(key, expect_number(range), describe(*n));
    }
    if (!std::isfinite(v) || !range.ok(v)) fail(key, expect_number(range), describe(*n));
    return v;
  }

  // An integer key (a float, even 8.0, is an error). Absent: the default, or an error when it is required.
  int integer(std::string_view key, std::optional<int> dflt, const Range& range = any_number()) {
    describe_key(key, "integer", expect_integer(range), !dflt, range.ok);
    auto v = optional_integer(key, range);
    if (v) return *v;
    if (!dflt && g_schema) return 1;
    if (!dflt) missing(key, expect_integer(range));
    return *dflt;
  }

  std::optional<int> optional_integer(std::string_view key, const Range& range = any_number()) {
    auto v = optional_int64(key, range);
    if (!v) return std::nullopt;
    // The key is stored in an int: say the upper bound too, or "expected an integer >= 8" would refuse a value >= 8.
    if (*v < std::numeric_limits<int>::min() || *v > std::numeric_limits<int>::max())
      fail(key,
           range.what.empty() ? "an integer in [-2147483648, 2147483647]"
                              : expect_integer(range) + " and <= 2147483647",
           describe(*lookup(key)));
    return static_cast<int>(*v);
  }

  // A 64-bit integer key (seeds, counts).
  std::optional<std::int64_t> optional_int64(std::string_view key, const Range& range = any_number()) {
    describe_key(key, "integer", expect_integer(range), false, range.ok);
    const toml::node* n = lookup(key);
    if (!n) return std::nullopt;
    auto i = n->as_integer();
    if (!i) fail(key, expect_integer(range), describe(*n));
    const std::int64_t v = i->get();
    if (!range.ok(static_cast<double>(v))) fail(key, expect_integer(range), describe(*n));
    return v;
  }

  // A string key (non-empty when `nonempty`). Absent: the default, or an error when it is required.
  std::string string(std::string_view key, std::optional<std::string> dflt, bool nonempty = true) {
    const std::string what = nonempty ? "a non-empty string" : "a string";
    describe_key(key, "string", what, !dflt);
    const toml::node* n = lookup(key);
    if (!n) {
      if (!dflt && g_schema) return "x";
      if (!dflt) missing(key, what);
      return *dflt;
    }
    auto s = n->as_string();
    if (!s || (nonempty && s->get().empty())) fail(key, what, describe(*n));
    return s->get();
  }

  bool boolean(std::string_view key, bool dflt) {
    describe_key(key, "boolean", "a boolean (true or false)", false);
    const toml::node* n = lookup(key);
    if (!n) return dflt;
    auto b = n->as_boolean();
    if (!b) fail(key, "a boolean (true or false)", describe(*n));
    return b->get();
  }

  // An array of finite numbers (integers accepted), each in `range`; `length` > 0 fixes the length, otherwise at
  // least one element. Absent: nullopt, or an error when `required`.
  std::optional<std::vector<double>> numbers(std::string_view key, bool required, std::size_t length = 0,
                                             const Range& range = any_number()) {
    std::string what = length ? "an array of " + std::to_string(length) + " finite numbers"
                              : "a non-empty array of finite numbers";
    if (!range.what.empty()) what += " " + range.what;
    describe_key(key, "numbers", what, required, range.ok, {}, length);
    const toml::node* n = lookup(key);
    if (!n) {
      if (required && g_schema) return std::vector<double>(length ? length : 1, 1.0);
      if (required) missing(key, what);
      return std::nullopt;
    }
    auto a = n->as_array();
    if (!a) fail(key, what, describe(*n));
    if ((length && a->size() != length) || a->empty())
      fail(key, what, "an array of " + std::to_string(a->size()) + " element" + (a->size() == 1 ? "" : "s"));
    std::vector<double> out;
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node& e = *a->get(i);
      double v = 0.0;
      if (auto iv = e.as_integer()) {
        v = static_cast<double>(iv->get());
      } else if (auto fv = e.as_floating_point()) {
        v = fv->get();
      } else {
        fail(key, what, "element " + std::to_string(i + 1) + " " + describe(e));
      }
      if (!std::isfinite(v) || !range.ok(v)) fail(key, what, "element " + std::to_string(i + 1) + " " + describe(e));
      out.push_back(v);
    }
    return out;
  }

  // A string key that must be one of `choices`.
  std::string choice(std::string_view key, const std::string& dflt, const std::vector<std::string>& choices) {
    std::string what = "one of";
    for (std::size_t i = 0; i < choices.size(); ++i) what += (i ? ", \"" : " \"") + choices[i] + "\"";
    describe_key(key, "choice", what, false, {}, choices);
    const toml::node* n = lookup(key);
    if (!n) return dflt;
    auto s = n->as_string();
    if (!s) fail(key, what, describe(*n));
    for (const auto& c : choices)
      if (s->get() == c) return c;
    fail(key, what, describe(*n));
  }

  // An error about a combination of keys, reported at `key`.
  [[noreturn]] void conflict(std::string_view key, const std::string& expected, const std::string& got) const {
    fail(key, expected, got);
  }

  // Rejects every key of the section that no reader asked for.
  void finish() const {
    if (!table_) return;
    for (const auto& [k, v] : *table_) {
      if (std::find(asked_.begin(), asked_.end(), k.str()) != asked_.end()) continue;
      std::string known;
      for (const auto& a : asked_) known += (known.empty() ? "" : ", ") + a;
      fail(k.str(), "one of the keys of [" + section_ + "] (" + known + ")",
           "unknown key '" + one_line(std::string(k.str())) + "'");
    }
  }

 private:
  void describe_key(std::string_view key, const char* type, const std::string& expected, bool required,
                    std::function<bool(double)> accepts = {}, std::vector<std::string> choices = {},
                    std::size_t length = 0) const {
    if (!g_schema) return;
    for (const ConfigKey& k : *g_schema)
      if (k.section == section_ && k.key == key) return;  // number() then optional_number(): the first says more
    ConfigKey k;
    k.section = section_;
    k.array_section = label_.rfind("[[", 0) == 0;
    k.key = std::string(key);
    k.type = type;
    k.expected = expected;
    k.required = required;
    k.accepts = std::move(accepts);
    k.choices = std::move(choices);
    k.length = length;
    g_schema->push_back(std::move(k));
  }
  const toml::node* lookup(std::string_view key) {
    if (std::find(asked_.begin(), asked_.end(), key) == asked_.end()) asked_.emplace_back(key);
    return table_ ? table_->get(key) : nullptr;
  }
  static std::string expect_number(const Range& r) {
    return r.what.empty() ? "a finite number" : "a finite number " + r.what;
  }
  static std::string expect_integer(const Range& r) { return r.what.empty() ? "an integer" : "an integer " + r.what; }
  [[noreturn]] void fail(std::string_view key, const std::string& expected, const std::string& got) const {
    if (origins_) {
      auto it = origins_->find({table_, std::string(key)});
      if (it != origins_->end()) throw InputError(it->second + ": expected " + expected + ", got " + got);
    }
    throw InputError(source_ + ": " + label_ + " " + one_line(std::string(key)) + ": expected " + expected +
                     ", got " + got);
  }
  [[noreturn]] void missing(std::string_view key, const std::string& expected) const {
    fail(key, expected, "nothing (this key is required)");
  }

  const toml::table* table_;  // null when the section is absent: every key takes its default
  std::string section_;
  std::string source_;
  std::string label_;
  const OverrideOrigins* origins_;
  bool stored_ = false;             // reading capsflow's resolved text (to_toml), not a user's file
  std::vector<std::string> asked_;  // in the order the reader asked: how they are listed in messages
};

const char* flow_type_name(FlowType t) {
  return t == FlowType::Shear ? "shear" : t == FlowType::None ? "none" : "poiseuille";
}
const char* membrane_law_name(MembraneLaw l) {
  return l == MembraneLaw::Skalak ? "skalak" : l == MembraneLaw::SurfaceTension ? "surface-tension" : "neo-hookean";
}
MembraneLaw membrane_law_from_name(const std::string& n) {
  return n == "skalak" ? MembraneLaw::Skalak : n == "surface-tension" ? MembraneLaw::SurfaceTension
                                                                       : MembraneLaw::NeoHookean;
}

// ----------------------------------------------------------------------------------------------------------
// One reader per section. A key's default is the value of the default-constructed Config (config.hpp), its one
// home. Cross-checks between keys of different sections run after all sections are read.

void read_domain(SectionReader& r, Config& c) {
  c.domain.H = r.number("H", std::nullopt, positive());
  c.domain.Lx = r.number("Lx", std::nullopt, positive());
  c.domain.Lz = r.number("Lz", std::nullopt, positive());
  c.domain.viscosity = r.number("viscosity", c.domain.viscosity, positive());
}

void read_ggem(SectionReader& r, Config& c) {
  GgemOptions& g = c.ggem;
  g.alpha = r.number("alpha", g.alpha, positive());
  g.alpha_hm = r.number("alpha_hm", g.alpha_hm, in_half_open(0.0, 2.0));
  g.nx = r.integer("nx", g.nx, at_least(8));
  g.nz = r.integer("nz", g.nz, at_least(8));
  g.ny = r.integer("ny", g.ny, at_least(8));
  g.cutoff = r.number("cutoff", default_cutoff(g.alpha), positive());
  // Below 2 / alpha the local sum leaves out a screened kernel that is not small yet: wrong physics, silently (a
  // cutoff of 1e-300 gave Taylor D 1.9e-4 against 3.2e-5).
  if (g.cutoff * g.alpha < kMinCutoffAlpha)
    r.conflict("cutoff",
               "at least " + fmt(kMinCutoffAlpha) + " / alpha = " + fmt(kMinCutoffAlpha / g.alpha) +
                   " (the local kernel is not screened yet below it; default 3.5 / alpha = " +
                   fmt(default_cutoff(g.alpha)) + ")",
               fmt(g.cutoff));
  g.chebyshev_rule = r.choice("chebyshev_rule", g.chebyshev_rule, {"midchannel", "mean"});
}

void read_run(SectionReader& r, Config& c) {
  c.run.backend =
      parse_backend(r.choice("backend", backend_name(c.run.backend), {"serial", "threads", "device"}), "[run] backend");
  c.run.threads = r.integer("threads", c.run.threads, at_least(0));
}

void read_flow(SectionReader& r, Config& c) {
  const std::string t = r.choice("type", flow_type_name(c.flow.type), {"poiseuille", "shear", "none"});
  c.flow.type = t == "shear" ? FlowType::Shear : t == "none" ? FlowType::None : FlowType::Poiseuille;
  c.flow.shear_rate = r.number("shear_rate", c.flow.shear_rate, positive());
}

void read_capsules(SectionReader& r, Config& c) {
  CapsuleOptions& o = c.capsules;
  o.mesh_level = r.integer("mesh_level", o.mesh_level, in_closed(0, 4));
  o.membrane.inflation = r.number("inflation", o.membrane.inflation, at_least(0.0));
  o.inflation_given = r.given("inflation");
  o.membrane.law = membrane_law_from_name(
      r.choice("law", membrane_law_name(o.membrane.law), {"neo-hookean", "skalak", "surface-tension"}));
  o.membrane.skalak_C = r.number("skalak_c", o.membrane.skalak_C, positive());
  o.radius = r.number("radius", o.radius, positive());
  o.velocity_projection = r.boolean("velocity_projection", o.velocity_projection);
  o.volume_correction = r.boolean("volume_correction", o.volume_correction);
}

// One [[species]] table (called once per element, in file order).
void read_species(SectionReader& r, Config& c) {
  SpeciesSpec s;
  s.name = r.string("name", std::nullopt);
  // The output stores the names joined by ',' (/capsules/species@names).
  // Control characters cannot appear in the XML of the XDMF index or the SVG figures, nor in a one-line message.
  const bool control = std::any_of(s.name.begin(), s.name.end(), [](char ch) {
    const auto u = static_cast<unsigned char>(ch);
    return u < 0x20 || u == 0x7f;
  });
  if (s.name.find(',') != std::string::npos || control)
    r.conflict("name", "a name without ',' and without control characters",
               "string \"" + printable(s.name) + "\"");
  s.ca = r.number("ca", std::nullopt, positive());
  s.bending_modulus = r.number("bending_modulus", s.bending_modulus, at_least(0.0));
  s.radius = r.optional_number("radius", positive());
  const std::string shape = r.choice("shape", "sphere", {"sphere", "spheroid", "biconcave"});
  s.shape.kind = shape == "spheroid" ? ShapeKind::Spheroid : shape == "biconcave" ? ShapeKind::Biconcave
                                                                                  : ShapeKind::Sphere;
  const std::optional<double> aspect = r.optional_number("aspect", positive());
  if (s.shape.kind == ShapeKind::Spheroid) {
    if (!aspect) r.conflict("aspect", "a finite number > 0 (c / b) with shape = \"spheroid\"", "nothing");
    s.shape.aspect = *aspect;
  } else if (aspect) {
    r.conflict("aspect", "no aspect unless shape = \"spheroid\"", "aspect = " + fmt(*aspect) + " with shape = \"" +
               shape + "\"");
  }
  const std::string law = r.choice("law", "", {"neo-hookean", "skalak", "surface-tension"});
  if (!law.empty()) s.law = membrane_law_from_name(law);
  s.skalak_c = r.optional_number("skalak_c", positive());
  s.inflation = r.optional_number("inflation", at_least(0.0));
  // A drop has no reference state to inflate from: a written inflation (even 0) is a mistake, refused. The law may
  // come from [capsules] (read before [[species]]).
  if (s.law.value_or(c.capsules.membrane.law) == MembraneLaw::SurfaceTension && r.given("inflation"))
    r.conflict("inflation",
               std::string("no inflation with ") + (s.law ? "law" : "[capsules] law") +
                   " = \"surface-tension\" (a drop has no reference state to inflate from)",
               "inflation = " + fmt(*s.inflation));
  // A drop relaxes to a sphere under its tension; the red cell's biconcave disc is a capsule's stress-free shape, and
  // a drop started from it folds at the dimples and stops early.
  if (s.law.value_or(c.capsules.membrane.law) == MembraneLaw::SurfaceTension && s.shape.kind == ShapeKind::Biconcave)
    r.conflict("shape",
               std::string("shape = \"sphere\" or \"spheroid\" with ") + (s.law ? "law" : "[capsules] law") +
                   " = \"surface-tension\" (a drop relaxes to a sphere; \"biconcave\" is a capsule's rest shape)",
               "shape = \"biconcave\"");
  s.viscosity_ratio = r.number("viscosity_ratio", s.viscosity_ratio, positive());
  c.species.push_back(std::move(s));
}

// Read after [[species]], so that fractions can default to {1} for a single species.
void read_suspension(SectionReader& r, Config& c) {
  if (!r.present()) return;
  SuspensionSpec s;
  s.volume_fraction = r.optional_number("volume_fraction", in_open(0.0, 0.5));
  if (auto f = r.numbers("fractions", c.species.size() > 1, 0, in_closed(0.0, 1.0))) {
    s.fractions = *f;
  } else {
    s.fractions = {1.0};
  }
  if (auto n = r.optional_int64("count", at_least(1))) s.count = static_cast<long>(*n);
  if (auto seed = r.optional_int64("seed", at_least(0))) s.seed = static_cast<std::uint64_t>(*seed);
  if (!s.volume_fraction && !s.count)
    r.number("volume_fraction", std::nullopt, in_open(0.0, 0.5));  // throws: "... required"
  if (s.volume_fraction && s.count)
    r.conflict("count", "either count or volume_fraction, not both",
               "count = " + std::to_string(*s.count) + " and volume_fraction = " + fmt(*s.volume_fraction));
  c.suspension = std::move(s);
}

// One [[capsule]] table (called once per element, in file order).
void read_capsule(SectionReader& r, Config& c) {
  CapsuleSpec s;
  s.species = r.string("species", std::nullopt);
  const std::vector<double> x = *r.numbers("center", true, 3);
  s.center = {x[0], x[1], x[2]};
  s.pinned = r.boolean("pinned", false);
  if (auto o = r.numbers("orientation", false, 3)) {
    if ((*o)[0] == 0.0 && (*o)[1] == 0.0 && (*o)[2] == 0.0)
      r.conflict("orientation", "a non-zero axis [x, y, z]", "[0, 0, 0]");
    s.orientation = std::array<double, 3>{(*o)[0], (*o)[1], (*o)[2]};
  }
  c.capsule_list.push_back(std::move(s));
}

void read_time(SectionReader& r, Config& c) {
  c.time.end = r.optional_number("end", positive());
  c.time.step_rule = r.choice("step_rule", step_rule_name(c.time.step_rule), {"membrane", "paper"}) == "paper"
                         ? StepRule::Paper
                         : StepRule::Membrane;
  c.time.cfl = r.number("cfl", c.time.cfl, positive());
  c.time.near_contact_factor = r.number("near_contact_factor", c.time.near_contact_factor, in_half_open(0.0, 1.0));
  c.time.bending_cfl = r.number("bending_cfl", c.time.bending_cfl, positive());
  c.time.c_gap = r.number("c_gap", c.time.c_gap, positive());
  // > 0: the contact control keeps this gap; with 0 it could not tell touching from overlapping surfaces.
  c.time.min_gap = r.number("min_gap", c.time.min_gap, positive());
  c.time.dt_floor = r.number("dt_floor", c.time.dt_floor, positive());
  c.time.max_step_ratio = r.number("max_step_ratio", c.time.max_step_ratio, at_least(1.0));
  c.time.reference_ca = r.optional_number("reference_ca", positive());
  c.time.steady_stop = r.boolean("steady_stop", c.time.steady_stop);
  c.time.steady_rtol = r.number("steady_rtol", c.time.steady_rtol, positive());
  c.time.steady_atol = r.number("steady_atol", c.time.steady_atol, positive());
  c.time.steady_atol_D = r.number("steady_atol_d", c.time.steady_atol_D, positive());
  c.time.steady_window = r.number("steady_window", c.time.steady_window, positive());
  c.time.stop_pair_dx = r.optional_number("stop_pair_dx");
}

void read_gmres(SectionReader& r, Config& c) {
  c.gmres.tolerance = r.number("tolerance", c.gmres.tolerance, in_half_open(0.0, 0.1));
  c.gmres.restart = r.integer("restart", c.gmres.restart, in_closed(1, 1000));
  c.gmres.max_iterations = r.integer("max_iterations", c.gmres.max_iterations, in_closed(1, 100000));
}

void read_output(SectionReader& r, Config& c) {
  c.output.file = r.string("file", c.output.file);
  check_output_file_name(c.output.file, c.origin("[output] file"));
  c.output.every = r.number("every", c.output.every, positive());
  c.output.frames_every = r.number("frames_every", c.output.frames_every, positive());
  c.output.checkpoint_every = r.number("checkpoint_every", c.output.checkpoint_every, positive());
  c.output.profile_bins = r.integer("profile_bins", c.output.profile_bins, in_closed(1, 10000));
  c.output.compression = r.integer("compression", c.output.compression, in_closed(0, 9));
}

struct SectionSpec {
  const char* name;
  void (*read)(SectionReader&, Config&);
  bool array = false;  // an array of tables [[name]]: read is called once per element
};

// The known sections, in the order they are read (and listed in error messages).
constexpr SectionSpec kSections[] = {
    {"domain", read_domain},     {"ggem", read_ggem},
    {"run", read_run},           {"flow", read_flow},
    {"capsules", read_capsules}, {"species", read_species, true},
    {"suspension", read_suspension}, {"capsule", read_capsule, true},
    {"time", read_time},         {"gmres", read_gmres},
    {"output", read_output},
};

// Checks across keys, once every section is read. The message names the key the user is most likely to change.
void check_period_fits_cutoff(const Config& c, const char* key, double L, double cutoff) {
  // The local sum sees each source at most once per period (minimum image): r_c <= L / 2.
  if (L >= 2.0 * cutoff) return;
  // A cutoff from alpha's default is alpha's doing (alpha = 1e-300 used to be blamed on Lx).
  if (cutoff == default_cutoff(c.ggem.alpha))
    throw InputError(c.origin("[ggem] alpha") + ": alpha = " + fmt(c.ggem.alpha) + " gives the local cutoff 3.5 / alpha = " +
                     fmt(cutoff) + ", which needs [domain] " + key + " >= 2 * cutoff = " + fmt(2.0 * cutoff) + " (" +
                     key + " = " + fmt(L) + "); expected a larger alpha (or " + key + ")");
  throw InputError(c.origin(std::string("[domain] ") + key) + ": " + key + " = " + fmt(L) +
                   " is too small for the cutoff " + fmt(cutoff) + ": need " + key + " >= 2 * cutoff = " +
                   fmt(2.0 * cutoff));
}

[[noreturn]] void run_error(const Config& c, const std::string& where, const std::string& what) {
  throw InputError(c.origin(where) + ": " + one_line(what));
}

// Every species a drop (law = "surface-tension", its own or [capsules]'), so that no capsule uses [capsules]
// inflation; with no species, [capsules] law decides.
bool every_species_a_drop(const Config& c) {
  if (c.species.empty()) return c.capsules.membrane.law == MembraneLaw::SurfaceTension;
  for (std::size_t i = 0; i < c.species.size(); ++i)
    if (c.species_membrane(i).law != MembraneLaw::SurfaceTension) return false;
  return true;
}

// A [capsules] inflation written for drops only: a drop has no reference state, the key would do nothing.
void check_drop_inflation(const Config& c) {
  if (!c.capsules.inflation_given || !every_species_a_drop(c)) return;
  run_error(c, "[capsules] inflation",
            "expected no inflation when every capsule is a drop (law = \"surface-tension\": a drop has no reference "
            "state to inflate from), got inflation = " + fmt(c.capsules.membrane.inflation));
}

void cross_check(const Config& c) {
  check_period_fits_cutoff(c, "Lx", c.domain.Lx, c.ggem.cutoff);
  check_period_fits_cutoff(c, "Lz", c.domain.Lz, c.ggem.cutoff);
  // Sizes beyond int (alpha = 1e300, H = 1e300) would wrap to a tiny grid and change the physics silently.
  if (const std::string e = ggem_grid_size_error(c.domain, c.ggem); !e.empty()) {
    const std::size_t colon = e.find(": ");  // "[ggem] alpha: why": name the key's origin (file or --set)
    throw InputError(c.origin(e.substr(0, colon)) + e.substr(colon));
  }
}

// Capsules need room for the cutoff plus two radii in each period (method-spec P5).
// "radius " when every species is a sphere (the words of the messages before shapes existed), else "bounding radius ".
std::string radius_words(const Config& c) {
  for (const SpeciesSpec& sp : c.species)
    if (sp.shape.kind != ShapeKind::Sphere) return "bounding radius ";
  return "radius ";
}

// `a` is the largest bounding radius of the species (the radius, for spheres).
void check_period_fits_capsules(const Config& c, const char* key, double L) {
  const double a = c.max_bounding_radius(), need = 2.0 * (c.ggem.cutoff + 2.0 * a);
  if (L >= need) return;
  run_error(c, std::string("[domain] ") + key,
            std::string(key) + " = " + fmt(L) + " is too small for capsules of " + radius_words(c) + fmt(a) +
                " with the cutoff " +
                fmt(c.ggem.cutoff) + ": need " + key + " >= 2 (cutoff + 2a) = " + fmt(need) + " (method-spec P5)");
}

// Cross-checks of the run sections (see config.hpp for which run where).
void check_run_sections(const Config& c) {
  if (c.suspension && !c.capsule_list.empty())
    run_error(c, "[suspension]",
              "expected either [suspension] (random placement) or [[capsule]] (explicit capsules), got both");

  for (std::size_t i = 0; i < c.species.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (c.species[i].name == c.species[j].name)
        run_error(c, "[[species]] " + std::to_string(i + 1) + " name",
                  "expected a name that no other [[species]] uses, got string \"" + c.species[i].name +
                      "\" (also [[species]] " + std::to_string(j + 1) + ")");

  if (c.defines_capsules() && c.species.empty())
    run_error(c, "[[species]]", "expected at least one [[species]] (name, ca) for the capsules, got none");

  if (c.time.steady_stop && c.defines_capsules()) {
    bool all_pinned = !c.suspension;
    for (const CapsuleSpec& k : c.capsule_list) all_pinned = all_pinned && k.pinned;
    if (!all_pinned)
      run_error(c, "[time] steady_stop",
                "expected every capsule pinned ([[capsule]] pinned = true) for a stop at steady state, got free "
                "capsules");
  }

  if (c.time.stop_pair_dx && (c.suspension || c.capsule_list.size() != 2))
    run_error(c, "[time] stop_pair_dx",
              "expected exactly two [[capsule]] entries (a pair) for a stop on their separation, got " +
                  (c.suspension ? std::string("[suspension]")
                                : std::to_string(c.capsule_list.size()) + " [[capsule]]"));

  if (c.time.reference_ca && !c.species.empty()) {
    double ca_min = c.species[0].ca;
    for (const SpeciesSpec& sp : c.species) ca_min = std::min(ca_min, sp.ca);
    // A larger reference Ca would step the stiffest capsules beyond the rule's stability margin (D8).
    if (*c.time.reference_ca > ca_min)
      run_error(c, "[time] reference_ca",
                "expected a number <= the smallest [[species]] ca (" + fmt(ca_min) + "), got " +
                    fmt(*c.time.reference_ca));
  }

  if (c.suspension) {
    const auto& f = c.suspension->fractions;
    if (f.size() != c.species.size())
      run_error(c, "[suspension] fractions",
                "expected one fraction per [[species]] (" + std::to_string(c.species.size()) + "), got " +
                    std::to_string(f.size()));
    double sum = 0.0;
    for (double v : f) sum += v;
    if (!(std::abs(sum - 1.0) <= 1e-9 * static_cast<double>(f.size())))
      run_error(c, "[suspension] fractions", "expected number fractions that sum to 1, got sum " + fmt(sum));
  }

  for (std::size_t i = 0; i < c.capsule_list.size(); ++i)
    if (c.species_index(c.capsule_list[i].species) < 0) {
      std::string known;
      for (const auto& s : c.species) known += (known.empty() ? "\"" : ", \"") + s.name + "\"";
      run_error(c, "[[capsule]] " + std::to_string(i + 1) + " species",
                "expected the name of a [[species]] (" + (known.empty() ? std::string("none defined") : known) +
                    "), got string \"" + c.capsule_list[i].species + "\"");
    }

  if (!c.defines_capsules()) return;

  // Every species must fit between the walls: the largest bounding radius decides.
  const double amax = c.max_bounding_radius(), gap = c.time.min_gap, H = c.domain.H;
  if (amax + gap > H - amax - gap)
    run_error(c, "[domain] H",
              "H = " + fmt(H) + " is too narrow for capsules of " + radius_words(c) + fmt(amax) + " with min_gap " +
                  fmt(gap) + ": need H >= 2 (a + min_gap) = " + fmt(2.0 * (amax + gap)));
  check_period_fits_capsules(c, "Lx", c.domain.Lx);
  check_period_fits_capsules(c, "Lz", c.domain.Lz);

  if (c.suspension && c.suspension->count) {
    const double vcap = mean_capsule_volume(c);
    const double phi = static_cast<double>(*c.suspension->count) * vcap / (H * c.domain.Lx * c.domain.Lz);
    if (!(phi < 0.5))
      run_error(c, "[suspension] count",
                "expected a count whose volume fraction N_p (4/3 pi a^3) / (H Lx Lz) is < 0.5, got count = " +
                    std::to_string(*c.suspension->count) + " (volume fraction " + fmt(phi) + ")");
  }

  for (std::size_t i = 0; i < c.capsule_list.size(); ++i) {
    const auto& p = c.capsule_list[i].center;
    const double a = c.species_bounding_radius(static_cast<std::size_t>(c.species_index(c.capsule_list[i].species)));
    const double ylo = a + gap, yhi = H - a - gap;
    const std::string where = "[[capsule]] " + std::to_string(i + 1) + " center";
    const std::string name = "capsule " + std::to_string(i + 1);
    const double tol = 1e-12 * std::max(1.0, H);  // exactly at a + min_gap is allowed, whatever the rounding
    if (p[1] < ylo - tol || p[1] > yhi + tol) {
      const bool low = p[1] < ylo;
      const bool crosses = low ? p[1] - a < 0.0 : p[1] + a > H;
      const std::string how = crosses ? " crosses the wall " : " comes within min_gap of the wall ";
      run_error(c, where,
                name + " at y = " + fmt(p[1]) + how + (low ? "y = 0" : "y = H = " + fmt(H)) +
                    ": needs a + min_gap <= y <= H - a - min_gap (" + fmt(ylo) + " <= y <= " + fmt(yhi) + ")");
    }
  }
  for (std::size_t i = 0; i < c.capsule_list.size(); ++i)
    for (std::size_t j = 0; j < i; ++j) {
      const auto& p = c.capsule_list[i].center;
      const auto& q = c.capsule_list[j].center;
      const double ri = c.species_bounding_radius(static_cast<std::size_t>(c.species_index(c.capsule_list[i].species)));
      const double rj = c.species_bounding_radius(static_cast<std::size_t>(c.species_index(c.capsule_list[j].species)));
      const double dmin = ri + rj + gap;  // 2a + min_gap for equal spheres, bit for bit
      const double dx = min_image(p[0] - q[0], c.domain.Lx), dy = p[1] - q[1],
                   dz = min_image(p[2] - q[2], c.domain.Lz);
      const double d = std::sqrt(dx * dx + dy * dy + dz * dz);
      if (d < dmin * (1.0 - 1e-12))  // exactly 2a + min_gap apart is allowed, whatever the rounding of d
        run_error(c, "[[capsule]] " + std::to_string(i + 1) + " center",
                  "capsule " + std::to_string(i + 1) + " overlaps capsule " + std::to_string(j + 1) +
                      ": centre distance " + fmt(d) + " (nearest periodic image) < " +
                      (ri == rj ? std::string("2a") : std::string("r_i + r_j (bounding radii)")) + " + min_gap = " +
                      fmt(dmin));
    }
}

// The section list as messages give it: "[domain], [ggem], ..., [[species]], ...".
std::string known_sections() {
  std::string known;
  for (const auto& s : kSections)
    known += std::string(known.empty() ? "" : ", ") + (s.array ? "[[" : "[") + s.name + (s.array ? "]]" : "]");
  return known;
}

const SectionSpec* find_section(const std::string& name) {
  for (const auto& s : kSections)
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
  for (const auto& s : kSections) {
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
                                           "gmres.restart"};
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

void check_output_file_name(const std::string& file, const std::string& where) {
  const std::filesystem::path p(file);
  if (file.empty() || p.filename().empty() || p.filename() == "." || p.filename() == "..")
    throw InputError(where + ": expected a file name (OUT.h5), got \"" + one_line(file) + "\"");
  // OUT.xdmf names OUT.h5 as "OUT.h5:/frames/...": readers split at the first ':'.
  if (p.filename().string().find(':') != std::string::npos)
    throw InputError(where + ": expected a file name without ':' (the XDMF index refers to the file as "
                     "NAME:/path), got \"" + one_line(file) + "\"");
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

void validate_run_config(const Config& c) {
  if (c.species.empty())
    run_error(c, "[[species]]", "expected at least one [[species]] (name, ca) for capsflow run, got none");
  if (!c.defines_capsules())
    run_error(c, "[suspension]",
              "expected either [suspension] (random placement) or [[capsule]] (explicit capsules) for capsflow run, "
              "got neither");
  if (!c.time.end)
    run_error(c, "[time] end", "expected a finite number > 0 (strain units), got nothing (required by capsflow run)");
  cross_check(c);
  check_run_sections(c);
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

std::vector<ConfigKey> config_keys() {
  std::vector<ConfigKey> keys;
  g_schema = &keys;
  struct Reset {
    ~Reset() { g_schema = nullptr; }
  } reset;
  const toml::table empty;
  Config c;
  c.species.resize(2);  // so that [suspension] asks for fractions as it does with several species
  for (const auto& s : kSections) {
    SectionReader r(&empty, s.name, "<schema>", s.array ? "[[" + std::string(s.name) + "]] 1" : "");
    s.read(r, c);
  }
  return keys;
}

std::string to_toml(const Config& c) {
  // Built as a toml++ table and written by its formatter (keys sorted within each table; floats as the shortest text
  // that reads back to the same double, so that parse_config(to_toml(c)) reproduces c bit for bit).
  toml::table domain{{"H", c.domain.H}, {"Lx", c.domain.Lx}, {"Lz", c.domain.Lz}, {"viscosity", c.domain.viscosity}};
  toml::table ggem{{"alpha", c.ggem.alpha},
                   {"alpha_hm", c.ggem.alpha_hm},
                   {"cutoff", c.ggem.cutoff},
                   {"chebyshev_rule", c.ggem.chebyshev_rule}};
  // 0 means "chosen from alpha_hm / chebyshev_rule": the key is left out (its value 0 is not a valid input).
  if (c.ggem.nx) ggem.insert("nx", static_cast<std::int64_t>(c.ggem.nx));
  if (c.ggem.nz) ggem.insert("nz", static_cast<std::int64_t>(c.ggem.nz));
  if (c.ggem.ny) ggem.insert("ny", static_cast<std::int64_t>(c.ggem.ny));
  toml::table run{{"backend", backend_name(c.run.backend)}, {"threads", static_cast<std::int64_t>(c.run.threads)}};
  toml::table flow{{"type", flow_type_name(c.flow.type)}, {"shear_rate", c.flow.shear_rate}};
  toml::table capsules{{"mesh_level", static_cast<std::int64_t>(c.capsules.mesh_level)},
                       {"law", membrane_law_name(c.capsules.membrane.law)},
                       {"skalak_c", c.capsules.membrane.skalak_C},
                       {"radius", c.capsules.radius},
                       {"velocity_projection", c.capsules.velocity_projection},
                       {"volume_correction", c.capsules.volume_correction}};
  // Left out when every capsule is a drop: no drop uses it, and an input that wrote it is refused.
  if (!every_species_a_drop(c)) capsules.insert("inflation", c.capsules.membrane.inflation);
  toml::array species;
  for (const SpeciesSpec& s : c.species) {
    toml::table t{{"name", s.name}, {"ca", s.ca}};
    if (s.bending_modulus > 0.0) t.insert("bending_modulus", s.bending_modulus);  // files without it stay as they were
    // Likewise the per-species keys of issue 23: written when given (or not the default shape).
    if (s.radius) t.insert("radius", *s.radius);
    if (s.shape.kind != ShapeKind::Sphere)
      t.insert("shape", s.shape.kind == ShapeKind::Spheroid ? "spheroid" : "biconcave");
    if (s.shape.kind == ShapeKind::Spheroid) t.insert("aspect", s.shape.aspect);
    if (s.law) t.insert("law", membrane_law_name(*s.law));
    if (s.skalak_c) t.insert("skalak_c", *s.skalak_c);
    if (s.inflation) t.insert("inflation", *s.inflation);
    if (s.viscosity_ratio != 1.0) t.insert("viscosity_ratio", s.viscosity_ratio);
    species.push_back(std::move(t));
  }
  toml::table time{{"step_rule", step_rule_name(c.time.step_rule)},
                   {"cfl", c.time.cfl},
                   {"near_contact_factor", c.time.near_contact_factor},
                   {"bending_cfl", c.time.bending_cfl},
                   {"c_gap", c.time.c_gap},
                   {"min_gap", c.time.min_gap},
                   {"dt_floor", c.time.dt_floor},
                   {"max_step_ratio", c.time.max_step_ratio},
                   {"steady_stop", c.time.steady_stop},
                   {"steady_rtol", c.time.steady_rtol},
                   {"steady_atol", c.time.steady_atol},
                   {"steady_atol_d", c.time.steady_atol_D},
                   {"steady_window", c.time.steady_window}};
  if (c.time.end) time.insert("end", *c.time.end);
  if (c.time.reference_ca) time.insert("reference_ca", *c.time.reference_ca);
  if (c.time.stop_pair_dx) time.insert("stop_pair_dx", *c.time.stop_pair_dx);
  toml::table output{{"file", c.output.file},
                     {"every", c.output.every},
                     {"frames_every", c.output.frames_every},
                     {"checkpoint_every", c.output.checkpoint_every},
                     {"profile_bins", static_cast<std::int64_t>(c.output.profile_bins)},
                     {"compression", static_cast<std::int64_t>(c.output.compression)}};
  toml::table root{{"domain", std::move(domain)}, {"ggem", std::move(ggem)},         {"run", std::move(run)},
                   {"flow", std::move(flow)},     {"capsules", std::move(capsules)}, {"species", std::move(species)},
                   {"time", std::move(time)},     {"output", std::move(output)}};
  if (c.suspension) {
    const SuspensionSpec& s = *c.suspension;
    toml::array fractions;
    for (double f : s.fractions) fractions.push_back(f);
    toml::table susp{{"fractions", std::move(fractions)}, {"seed", static_cast<std::int64_t>(s.seed)}};
    if (s.volume_fraction) susp.insert("volume_fraction", *s.volume_fraction);
    if (s.count) susp.insert("count", static_cast<std::int64_t>(*s.count));
    root.insert("suspension", std::move(susp));
  }
  if (!c.capsule_list.empty()) {
    toml::array list;
    for (const CapsuleSpec& s : c.capsule_list) {
      toml::table t{{"species", s.species},
                    {"center", toml::array{s.center[0], s.center[1], s.center[2]}},
                    {"pinned", s.pinned}};
      if (s.orientation) t.insert("orientation", toml::array{(*s.orientation)[0], (*s.orientation)[1],
                                                             (*s.orientation)[2]});
      list.push_back(std::move(t));
    }
    root.insert("capsule", std::move(list));
  }
  // Written when a viscosity ratio asks for the solve or a key differs from its default: files of lambda = 1 runs
  // stay as they were.
  if (c.has_viscosity_contrast() || !(c.gmres == GmresConfig{}))
    root.insert("gmres", toml::table{{"tolerance", c.gmres.tolerance},
                                     {"restart", static_cast<std::int64_t>(c.gmres.restart)},
                                     {"max_iterations", static_cast<std::int64_t>(c.gmres.max_iterations)}});
  std::ostringstream o;
  o << kResolvedHeader << " written by capsflow from " << one_line(c.source)
    << "\n"
    << root << "\n";
  return o.str();
}

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
