#pragma once
// The run configuration: one TOML file, validated in one place (docs/usage.md lists every key).
//
// load_config() rejects unknown sections and keys, wrong types and out-of-range values with an InputError
// whose one-line message names the file, the key and what was expected.
//
// The sections of `capsflow run` ([flow], [capsules], [[species]], [suspension], [[capsule]], [time], [output])
// are optional for the parser: a file with only [domain], [ggem], [run] (capsflow green) parses as before, and the
// run sections take their defaults. What is checked where:
//   parse_config        every key present (type, range); [suspension] and [[capsule]] not both; unique species
//                       names; fractions per species summing to 1; capsule species that exist; and, as soon as the
//                       file defines capsules ([suspension] or [[capsule]]), the box (Lx, Lz >= 2 (cutoff + 2a):
//                       no capsule meets its own periodic image) and the explicit capsules (inside the walls with
//                       min_gap, no overlap).
//   validate_run_config what `capsflow run` needs on top: at least one [[species]], either [suspension] or
//                       [[capsule]], and [time] end; it re-runs the cross-checks (a Config built in code is checked
//                       the same way).
#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "host/base/backend_select.hpp"
#include "host/state/membrane_parameters.hpp"
#include "host/state/shapes.hpp"
#include "host/solver/slit_parameters.hpp"
#include "kernels/backend.hpp"

namespace capsflow {

struct RunOptions {
  Backend backend = default_backend();  // [run] backend = "serial" | "threads" | "device"; default: the fastest
                                        // this build and machine offer (backend_select.hpp)
  int threads = 0;                      // [run] threads for 'threads' (0: the CPUs the process may use)
};

// Units of the run sections (decision D1): lengths in units of the capsule radius a's unit (the same as [domain]),
// times in strain units 1/gammadot (gammadot = [flow] shear_rate).
enum class FlowType { Poiseuille, Shear, None };

struct FlowOptions {
  FlowType type = FlowType::Poiseuille;  // [flow] type = "poiseuille" | "shear" | "none"
  double shear_rate = 1.0;               // [flow] shear_rate (> 0): the wall shear rate gammadot_w for Poiseuille
                                         // (U_c = gammadot_w H / 4), the imposed rate for shear
};

struct CapsuleOptions {
  int mesh_level = 2;             // [capsules] mesh_level, 0..4 (2: 162 nodes, 320 triangles)
  MembraneParameters membrane;    // [capsules] law ("neo-hookean"), skalak_c (1, > 0), inflation (beta 0.1, >= 0)
  double radius = 1.0;            // [capsules] radius a (> 0): the inflated initial radius (D7)
  bool inflation_given = false;   // [capsules] inflation written in the input (not its default): refused when every
                                  // capsule is a drop (issue 37)
  bool velocity_projection = true;  // [capsules] velocity_projection: project each capsule's node velocities to zero
                                    // discrete volume rate before the time update (D11, revised: on by default)
  bool volume_correction = true;    // [capsules] volume_correction: restore each capsule's initial volume after every
                                    // step by a uniform normal displacement, the safety net for the O(dt^2)
                                    // remainder (D11, revised: on by default)
};

struct SpeciesSpec {              // one [[species]]
  std::string name;               // non-empty, unique
  double ca = 0.0;                // capillary number (> 0, required), D1
  double bending_modulus = 0.0;   // kb = kappa / (Gs a^2) (>= 0; 0: no bending resistance), docs/method.md "Bending"
  // Issue 23. Absent keys take the [capsules] value (Config::species_radius, species_membrane), so files without
  // them run as before.
  std::optional<double> radius;          // equal-volume radius (> 0)
  ShapeSpec shape;                       // shape = "sphere" | "spheroid" (with aspect = c / b > 0) | "biconcave"
  std::optional<MembraneLaw> law;        // law = "neo-hookean" | "skalak"
  std::optional<double> skalak_c;        // skalak_c (> 0)
  std::optional<double> inflation;       // inflation (beta >= 0; the reference is the shape scaled by 1/(1 + beta))
                                         // (refused, even 0, for a drop: law = "surface-tension")
  // Issue 22: viscosity of the inner fluid over the suspending fluid's (> 0; 1: no double layer, today's path).
  double viscosity_ratio = 1.0;
};

struct SuspensionSpec {           // [suspension]: random sequential placement (initial_conditions.hpp)
  std::optional<double> volume_fraction;  // phi in (0, 0.5); required unless count is given (not both)
  std::vector<double> fractions;          // number fraction per [[species]], in file order, >= 0, sum 1;
                                          // default {1} when there is exactly one species
  std::optional<long> count;              // N_p >= 1; absent: round(phi H Lx Lz / (4/3 pi a^3))
  std::uint64_t seed = 1;                 // seed of std::mt19937_64 (integer >= 0)
};

struct CapsuleSpec {              // one [[capsule]]: an explicit capsule
  std::string species;            // a [[species]] name (required)
  std::array<double, 3> center{}; // [x, y, z] (required); r + min_gap <= y <= H - r - min_gap, r the species'
                                  // bounding radius
  bool pinned = false;            // kept at its centre (D10 protocol (b))
  std::optional<std::array<double, 3>> orientation;  // the direction of the shape's symmetry axis (body z);
                                                     // absent: along z (the identity)
};

// A step-ratio cap that never binds: the behaviour of runs made before the cap existed (restarted from their
// checkpoints). Finite, so that it survives to_toml / parse_config.
inline constexpr double kUncappedStepRatio = 1e300;

// [time] step_rule (docs/method.md section 4.1). Membrane: dt from the elements' size (the stability limit of the
// explicit membrane step), with a collision cap on closing gaps. Paper: the seed's rule, h including node pairs of
// different capsules (what runs before step_rule existed did; their checkpoints restart with it).
enum class StepRule { Membrane, Paper };
const char* step_rule_name(StepRule r);

struct TimeOptions {
  std::optional<double> end;      // [time] end (> 0, strain units); required by validate_run_config
  StepRule step_rule = StepRule::Membrane;  // [time] step_rule: "membrane" | "paper"
  double cfl = 0.5;               // [time] cfl (> 0): dt = cfl * Ca_ref * h / a_ref (D8; h per step_rule)
  double near_contact_factor = 1.0;  // [time] near_contact_factor (in (0, 1]): membrane rule, dt multiplied by it
                                     // while a capsule pair is closer than h_e (the stability probe's choice)
  double bending_cfl = 0.1;       // [time] bending_cfl (> 0): with bending, the membrane limit becomes
                                  // 1 / (1/dt_M + 1/dt_B), dt_B = bending_cfl mu gammadot min_k h_k^3 / kappa_k
                                  // (strain units; the probe's limit, docs/method.md section 4.1)
  double c_gap = 0.25;            // [time] c_gap (> 0): membrane rule, collision cap dt <= c_gap max(g, min_gap) / w
  double min_gap = 0.02;          // [time] min_gap (> 0, units of length): overlap control (D5)
  double dt_floor = 1e-6;         // [time] dt_floor (> 0, strain units): a step below this is an error
  double max_step_ratio = 2.0;    // [time] max_step_ratio (>= 1): cap on dt_n / dt_{n-1} (D8)
  std::optional<double> reference_ca;  // [time] reference_ca (> 0, <= the smallest species Ca): the Ca of the
                                       // time-step rule (D8); absent: the smallest Ca present
  bool steady_stop = false;       // [time] steady_stop: with every capsule pinned, stop once U_y and D are steady
  double steady_rtol = 1e-4;      // [time] steady_rtol (> 0): steady when |d/dt| < max(rtol |value|, atol), per strain
  double steady_atol = 1e-7;      // [time] steady_atol (> 0): the absolute floor for U_y (gammadot a per strain)
  double steady_atol_D = 1e-6;    // [time] steady_atol_D (> 0): the absolute floor for D (per strain)
  double steady_window = 2.0;     // [time] steady_window (> 0, strain units): records the slope is fitted over
  std::optional<double> stop_pair_dx;  // [time] stop_pair_dx (length; exactly two [[capsule]]): stop (exit 0) at the
                                       // first record where x_top - x_bottom (unwrapped centroids, top = the larger
                                       // y) >= this: the end of a pair collision (docs/analysis.md §12)
};

// The interface solve's default tolerance relative to a given [ggem] tolerance (the operator's stated accuracy).
inline constexpr double kGmresPerGgemTolerance = 1e-3;

struct GmresConfig {             // [gmres]: the interface-velocity solve of a viscosity ratio other than 1
  double tolerance = 1e-6;       // [gmres] tolerance (in (0, 0.1]): relative residual |b - A u| / |b|; not given,
                                 // [ggem] tolerance x kGmresPerGgemTolerance where that is given
  int restart = 30;              // [gmres] restart (1..1000): Krylov vectors per cycle
  int max_iterations = 200;      // [gmres] max_iterations (1..100000): operator applications per step; a solve
                                 // that does not converge within them stops the run (exit 3, checkpoint)
  bool rigid_preconditioner = true;  // [gmres] preconditioner: "rigid" (each capsule's rigid motions scaled apart,
                                     // docs/method.md 3.1) or "none"; the answer's tolerance is the same
  bool operator==(const GmresConfig& o) const {
    return tolerance == o.tolerance && restart == o.restart && max_iterations == o.max_iterations &&
           rigid_preconditioner == o.rigid_preconditioner;
  }
};

// [quadrature]: the element rules of the local sums (docs/method_quadrature.md, "Rules and thresholds"; D4), by the
// distance d of a target from an element over the element's longest edge h_e. The defaults (issue 34; method.md 1.5)
// hold the local sums within 4.6e-6 (single layer) and 1.8e-6 (double layer) of converged sums on capsules 0.02-0.03
// apart (LocalSingleLayer and DoubleLayerSlit .DefaultRulesAccurateOnCloseCapsules), 170x below the default split's
// own error (7.8e-4 of the Green's function), in half the time of the finer rules of QuadratureOrders
// (fine_quadrature(): ~1e-6, the defaults before issue 34, which earlier runs continue with).
struct QuadratureOptions {
  int singular = 6;              // [quadrature] singular (2..20): n x n polar rule on the elements at a target node
                                 // (5 doubled the error on close capsules: 9.1e-6 against 4.6e-6)
  double far_ratio = 1.5;        // [quadrature] far_ratio: d/h_e >= it: the symmetric 7-point rule
  double symmetric_ratio = 1.5;  // [quadrature] symmetric_ratio (<= far_ratio): the 16-point rule up to far_ratio
                                 // (equal: that band left out)
  double mid_ratio = 0.75;       // [quadrature] mid_ratio (<= symmetric_ratio): regular_mid up to symmetric_ratio
  int regular_mid = 5;           // [quadrature] regular_mid (1..20): collapsed Gauss order
  int regular_near = 10;         // [quadrature] regular_near (1..20): collapsed Gauss order from near_ratio to mid_ratio
  double near_ratio = 0.3;       // [quadrature] near_ratio (> 0, <= mid_ratio): below it the near-singular rule
                                 // (8 points at 0.3-0.5 h_e left 1.8e-5 in the double layer: regular_near stays 10)
  int near_points = 6;           // [quadrature] near_points (2..20): its Gauss points per panel in angle and radius
                                 // (5: 3.4e-5 on close capsules)
  int kernel_degree = 9;         // [quadrature] kernel_degree (17 or 9): of the AVX-512 evaluator's polynomials of the
                                 // local kernels (9: 4.1e-7 of the Stokeslet; other evaluators: the 144-interval table)
  bool operator==(const QuadratureOptions& o) const {
    return singular == o.singular && far_ratio == o.far_ratio && symmetric_ratio == o.symmetric_ratio &&
           mid_ratio == o.mid_ratio && regular_mid == o.regular_mid && regular_near == o.regular_near &&
           near_ratio == o.near_ratio && near_points == o.near_points && kernel_degree == o.kernel_degree;
  }
  bool operator!=(const QuadratureOptions& o) const { return !(*this == o); }
};

// The rules of QuadratureOrders (kernels/element_quadrature.hpp), the defaults before issue 34 (~1e-6 of the
// velocity): what a run continues with when its stored configuration has no [quadrature] table (keep_earlier_build_rules).
QuadratureOptions fine_quadrature();

struct OutputOptions {
  std::string file = "capsflow-run.h5";  // [output] file (non-empty)
  double every = 0.1;                    // [output] every (> 0, strain units between time-series records)
  double frames_every = 1.0;             // [output] frames_every (> 0, strain units between mesh frames)
  double checkpoint_every = 10.0;        // [output] checkpoint_every (> 0, strain units between checkpoints)
  int profile_bins = 50;                 // [output] profile_bins (1..10000): wall-normal slabs of /series/profile
  int compression = 4;                   // [output] compression (0..9): deflate level of the series and frames
                                         // (with byte shuffle); 0 = none
};

struct Config {
  std::string source;  // file name, or "<embedded>" for the built-in demo
  SlitGeometry domain;  // [domain] H, Lx, Lz, viscosity
  GgemOptions ggem;     // [ggem] alpha, alpha_hm, nx, nz, ny, cutoff, chebyshev_rule, tolerance
  RunOptions run;       // [run]

  // capsflow run (all optional for the parser; see validate_run_config)
  FlowOptions flow;                          // [flow]
  CapsuleOptions capsules;                   // [capsules]
  std::vector<SpeciesSpec> species;          // [[species]], in file order
  std::optional<SuspensionSpec> suspension;  // [suspension]
  std::vector<CapsuleSpec> capsule_list;     // [[capsule]], in file order (numbered from 1 in messages)
  TimeOptions time;                          // [time]
  GmresConfig gmres;                         // [gmres]
  QuadratureOptions quadrature;              // [quadrature]
  OutputOptions output;                      // [output]

  // Keys set by an override (parse_config's `overrides`): "[suspension] seed" -> "--set suspension.seed", so that a
  // check across keys names the override, not the file, as the origin of a value.
  std::map<std::string, std::string> origins;

  bool defines_capsules() const { return suspension.has_value() || !capsule_list.empty(); }
  // How messages name the key `label` ("[run] backend", "[[capsule]] 2 center"): the override that set it, or
  // "<source>: <label>".
  std::string origin(const std::string& label) const;
  // Index of the species called `name` in `species`, or -1.
  int species_index(const std::string& name) const;
  // Species i's resolved values: its own key, or the [capsules] default.
  double species_radius(std::size_t i) const;
  MembraneParameters species_membrane(std::size_t i) const;
  // The step rule's Ca of species i (docs/method.md 4.1, 3.1): Ca (a_ref / a) g / f, a_ref the [capsules] radius, f
  // the law's stiffness factor, g the viscosity ratio's factor. The run and its estimate both take it from here.
  double species_step_ca(std::size_t i) const;
  // Radius of the sphere about the centre that holds species i's shape (shape_bounding_radius), and the largest.
  double species_bounding_radius(std::size_t i) const;
  double max_bounding_radius() const;
  // True when some species has a viscosity ratio other than 1 (the run solves for the interface velocity).
  bool has_viscosity_contrast() const;
};

// Mean capsule volume of the configured suspension: sum_i fraction_i (4/3) pi a_i^3 over the species ([suspension]
// fractions; a single species: its volume). Shapes enclose the volume of their equal-volume radius.
double mean_capsule_volume(const Config& c);

// Overrides: `--set section.key=value` on the command line, applied to the parsed TOML before any key is read, so
// that an override is checked exactly like the same key in the file; its messages name it ("--set suspension.seed:
// expected an integer >= 0, got integer -1"). Syntax (docs/usage.md "Overrides"):
//   key    section.key                      [domain] H, [suspension] seed, ...
//          section.N.key                    entry N (from 1, as in messages) of an array of tables: species.2.ca;
//                                           N = count + 1 appends an entry
//          species.NAME.key                 the [[species]] whose name is NAME: species.floppy.ca
//   value  a TOML value: 3, 0.5, 1e-3, true, "threads", [0.5, 0.5]; a bare word that is not TOML (threads) is
//          taken as a string
// A key may be given more than once; the last one wins.
struct ConfigOverride {
  std::string key;     // "suspension.seed"
  std::string value;   // "3"
  std::string origin;  // how messages name it: "--set suspension.seed", or an alias's option ("--end")
};

// "key=value" -> ConfigOverride (origin "--set key"); a malformed argument is an InputError naming it.
ConfigOverride parse_override(const std::string& arg);
std::vector<ConfigOverride> parse_overrides(const std::vector<std::string>& args);

// The command-line options --end T, --backend B, --threads N as the overrides time.end, run.backend, run.threads
// (their messages name the option: "--end: expected a finite number > 0, got integer -1").
std::vector<ConfigOverride> run_flag_overrides(const std::optional<double>& end,
                                               const std::optional<std::string>& backend,
                                               const std::optional<int>& threads);

// The keys that a continued run (--restart) may change: run control, not physics (docs/usage.md).
bool is_run_control_key(const std::string& key);
// Throws InputError for the first override that is not run control ("--set capsules.inflation: cannot change
// when continuing a run ...").
void check_restart_overrides(const std::vector<ConfigOverride>& overrides);

// Parses, applies the overrides in order, then reads and checks every section (see the top of this file).
Config parse_config(const std::string& text, const std::string& source_name,
                    const std::vector<std::string>& overrides = {});
Config resolve_config(const std::string& text, const std::string& source_name,
                      const std::vector<ConfigOverride>& overrides);
Config load_config(const std::string& path, const std::vector<ConfigOverride>& overrides = {});

// An output file name the run can use: a file name (not a directory) without ':' in its last component (the XDMF
// index refers to OUT.h5 as "OUT.h5:/frames/..."). Throws InputError "<where>: expected ..., got ...".
void check_output_file_name(const std::string& file, const std::string& where);

// What `capsflow run` needs beyond a parseable file (see above). Throws InputError "<file>: [section] key: ...".
void validate_run_config(const Config& c);

// The configuration as TOML with every key written (defaults filled in, doubles with 17 significant digits), so
// that parse_config(to_toml(c)) reproduces c exactly (overrides included: they are part of the values). Stored in
// every output and checkpoint (/parameters/config).
std::string to_toml(const Config& c);

}  // namespace capsflow
