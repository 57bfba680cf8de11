// The schema of the run configuration: which sections and keys exist, their types, ranges and defaults (one
// reader function per section, run by read_config and, in a describing mode, by config_keys()), and to_toml, which
// writes every key back. The typed access is config_reader.cpp; the checks across keys config_checks.cpp.
//
// A new key costs one line in its section's reader (its default is the default-constructed Config's, config.hpp)
// and one in to_toml; a new section one reader and one row in config_sections().
#include "host/physics/config_schema.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <optional>
#include <sstream>
#include <string>
#include <toml++/toml.h>
#include <utility>
#include <vector>

#include "host/base/backend_select.hpp"
#include "host/base/printable.hpp"
#include "host/physics/config_checks.hpp"
#include "host/physics/config_reader.hpp"

namespace capsflow {
namespace config_detail {
namespace {

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
  // A tolerance sets the defaults of alpha_hm and cutoff (the Chebyshev degree follows alpha_hm); keys given
  // explicitly win. Below 1e-4 the splitting's other errors (the clouds' truncation, the Chebyshev rule) stay.
  // 0 says "none" explicitly (the split's own defaults): a sweep over a preset that gives a tolerance pins its runs
  // to the defaults with it.
  const Range tolerance_range{
      [](double v) { return v == 0.0 || (v >= kMinGgemTolerance && v <= kMaxGgemTolerance); },
      "0 (none: the defaults) or in [" + fmt(kMinGgemTolerance) + ", " + fmt(kMaxGgemTolerance) + "]"};
  g.tolerance = r.number("tolerance", 0.0, tolerance_range);  // 0: absent
  const bool tol = g.tolerance > 0.0;
  const GgemOptions picked = tol ? with_ggem_tolerance(g, g.tolerance) : g;  // the defaults a tolerance sets
  g.alpha_hm = r.number("alpha_hm", picked.alpha_hm, in_half_open(0.0, 2.0));
  g.nx = r.integer("nx", g.nx, at_least(8));
  g.nz = r.integer("nz", g.nz, at_least(8));
  g.ny = r.integer("ny", g.ny, at_least(8));
  g.cutoff = r.number("cutoff", tol ? picked.cutoff : default_cutoff(g.alpha), positive());
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
  // Not given: a thousandth of [ggem] tolerance where that is given (the default 1e-6 is a thousandth of the default
  // split's ~1e-3): an interface velocity solved far below the operator's own error costs applications and changes
  // nothing (docs/method.md 3.1; at [ggem] tolerance 1e-2 and lambda 5, 1e-5 moves set A's capsules by 7e-6 a in 1.5
  // strain units against the tolerance's own 5.7e-4).
  const double dflt = c.ggem.tolerance > 0.0 ? c.ggem.tolerance * kGmresPerGgemTolerance : c.gmres.tolerance;
  c.gmres.tolerance = r.number("tolerance", dflt, in_half_open(0.0, 0.1));
  c.gmres.restart = r.integer("restart", c.gmres.restart, in_closed(1, 1000));
  c.gmres.max_iterations = r.integer("max_iterations", c.gmres.max_iterations, in_closed(1, 100000));
  c.gmres.rigid_preconditioner =
      r.choice("preconditioner", c.gmres.rigid_preconditioner ? "rigid" : "none", {"rigid", "none"}) == "rigid";
}

void read_quadrature(SectionReader& r, Config& c) {
  QuadratureOptions& q = c.quadrature;
  q.singular = r.integer("singular", q.singular, in_closed(2, 20));
  q.regular_mid = r.integer("regular_mid", q.regular_mid, in_closed(1, 20));
  q.regular_near = r.integer("regular_near", q.regular_near, in_closed(1, 20));
  q.near_points = r.integer("near_points", q.near_points, in_closed(2, 20));
  q.near_ratio = r.number("near_ratio", q.near_ratio, in_closed(0.01, 100.0));
  q.mid_ratio = r.number("mid_ratio", q.mid_ratio, in_closed(0.01, 100.0));
  q.symmetric_ratio = r.number("symmetric_ratio", q.symmetric_ratio, in_closed(0.01, 100.0));
  q.far_ratio = r.number("far_ratio", q.far_ratio, in_closed(0.01, 100.0));
  q.kernel_degree = r.integer("kernel_degree", q.kernel_degree, in_closed(9, 17));
  if (q.kernel_degree != 9 && q.kernel_degree != 17)
    r.conflict("kernel_degree", "17 (the whole table) or 9 (its first ten coefficients)",
               "integer " + std::to_string(q.kernel_degree));
  // The bands in d/h_e, from the element outward: near-singular < near_ratio <= regular_near < mid_ratio <=
  // regular_mid < symmetric_ratio <= 16-point rule < far_ratio <= 7-point rule. Equal thresholds leave a band out.
  const std::pair<const char*, double> chain[] = {{"near_ratio", q.near_ratio},
                                                  {"mid_ratio", q.mid_ratio},
                                                  {"symmetric_ratio", q.symmetric_ratio},
                                                  {"far_ratio", q.far_ratio}};
  for (std::size_t i = 1; i < 4; ++i)
    if (chain[i].second < chain[i - 1].second)
      r.conflict(chain[i].first,
                 std::string("at least ") + chain[i - 1].first + " (" + fmt(chain[i - 1].second) +
                     "): the bands run near_ratio <= mid_ratio <= symmetric_ratio <= far_ratio",
                 fmt(chain[i].second));
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

}  // namespace

const std::vector<SectionSpec>& config_sections() {
  static const std::vector<SectionSpec> sections = {
      {"domain", read_domain},         {"ggem", read_ggem},
      {"run", read_run},               {"flow", read_flow},
      {"capsules", read_capsules},     {"species", read_species, true},
      {"suspension", read_suspension}, {"capsule", read_capsule, true},
      {"time", read_time},             {"gmres", read_gmres},
      {"quadrature", read_quadrature}, {"output", read_output},
  };
  return sections;
}

}  // namespace config_detail

using namespace config_detail;

std::vector<ConfigKey> config_keys() {
  std::vector<ConfigKey> keys;
  const SchemaRecording recording(keys);
  const toml::table empty;
  Config c;
  c.species.resize(2);  // so that [suspension] asks for fractions as it does with several species
  for (const auto& s : config_sections()) {
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
  // For the record: alpha_hm and cutoff above are explicit, so they win when the text is read back.
  if (c.ggem.tolerance > 0.0) ggem.insert("tolerance", c.ggem.tolerance);
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
                                     {"max_iterations", static_cast<std::int64_t>(c.gmres.max_iterations)},
                                     {"preconditioner", c.gmres.rigid_preconditioner ? "rigid" : "none"}});
  // Always written: a stored configuration without this table is a run of a build before issue 34, whose default
  // rules were the finer ones (keep_earlier_build_rules continues it with them).
  {
    const QuadratureOptions& q = c.quadrature;
    root.insert("quadrature", toml::table{{"singular", static_cast<std::int64_t>(q.singular)},
                                          {"far_ratio", q.far_ratio},
                                          {"symmetric_ratio", q.symmetric_ratio},
                                          {"mid_ratio", q.mid_ratio},
                                          {"regular_mid", static_cast<std::int64_t>(q.regular_mid)},
                                          {"regular_near", static_cast<std::int64_t>(q.regular_near)},
                                          {"near_ratio", q.near_ratio},
                                          {"near_points", static_cast<std::int64_t>(q.near_points)},
                                          {"kernel_degree", static_cast<std::int64_t>(q.kernel_degree)}});
  }
  std::ostringstream o;
  o << kResolvedHeader << " written by capsflow from " << one_line(c.source)
    << "\n"
    << root << "\n";
  return o.str();
}

}  // namespace capsflow
