// `capsflow flow` (flow_command.hpp): options, input checks before any file is written, the evaluation
// (run/flow_field.hpp), FLOW.h5 + FLOW.xdmf, and the picture by tools/capsflow_flow.py.
#include "host/cli/flow_command.hpp"

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "host/base/atomic_file.hpp"
#include "host/base/backend_select.hpp"
#include "host/base/csv_io.hpp"
#include "host/base/errors.hpp"
#include "host/base/stopwatch.hpp"
#include "host/base/thread_limits.hpp"
#include "host/cli/figures_command.hpp"
#include "host/cli/subprocess.hpp"
#include "host/run/flow_field.hpp"
#include "host/run/frame_start.hpp"
#include "host/run/run_layout.hpp"

namespace capsflow {

namespace fs = std::filesystem;

namespace {

constexpr const char* kScript = "capsflow_flow.py";

// The configuration the flow is evaluated with: the run's own, on a host backend (the evaluation at points is host
// code), with --backend and --threads applied as the overrides run.backend and run.threads.
Config flow_config(const FrameStart& f, const FlowCommandOptions& o, std::ostream& log) {
  Config cfg = f.source;
  if (o.backend || o.threads)
    cfg = resolve_config(to_toml(f.source), f.source.source, run_flag_overrides(std::nullopt, o.backend, o.threads));
  if (cfg.run.backend == Backend::Device) {
    cfg.run.backend = Backend::Threads;
    if (!o.quiet) log << "capsflow flow: the run used the device backend; the flow is evaluated with 'threads'\n";
  }
  check_thread_count(cfg.run.threads, cfg.origin("[run] threads"),
                     cfg.run.backend == Backend::Threads ? log : null_stream());
  require_backend(cfg.run.backend, cfg.origin("[run] backend"));
  if (cfg.run.backend == Backend::Threads) set_host_threads(cfg.run.threads);
  return cfg;
}

struct FlowPaths {
  fs::path h5, xdmf, png;
};

// FLOW.h5 and its companions, each checked as a new output (--force replaces) that is none of the inputs.
FlowPaths flow_paths(const FlowCommandOptions& o) {
  const fs::path h5(o.out);
  if (h5.extension() != ".h5") throw InputError("--out " + o.out + ": expected a file name ending in .h5");
  FlowPaths p{h5, fs::path(h5).replace_extension(".xdmf"), fs::path(h5).replace_extension(".png")};
  std::vector<std::pair<fs::path, std::string>> inputs = {{o.run, "run output"},
                                                          {run_paths(o.run).checkpoint, "run's checkpoint"}};
  if (!o.points.empty()) inputs.emplace_back(o.points, "points file");
  for (const fs::path& f : {p.h5, p.xdmf, p.png}) {
    check_not_an_input(f, inputs);
    ensure_can_create(f, o.force);
  }
  return p;
}

// FLOW.png by the script, beside FLOW.h5; a note instead when python3 with matplotlib is not to be had. 1 when the
// script failed (the data are written by then).
int draw_picture(const FlowPaths& p, const FlowCommandOptions& o, std::ostream& log) {
  const FiguresPython py = find_figures_python();
  fs::path script;
  std::string problem = py.problem;
  try {
    script = find_share_script(kScript, "capsflow flow");
  } catch (const InputError& e) {
    problem = e.what();
  }
  if (py.python.empty() || script.empty()) {
    log << "capsflow flow: no picture: " << problem << "\n";
    return 0;
  }
  std::vector<std::string> argv = {py.python, script.string(), p.h5.string(), p.png.string()};
  ProcessOptions po;
  po.capture_stdout = true;
  po.own_group = true;  // the drawing ends with capsflow, whatever ends it (subprocess.hpp)
  const ProcessResult r = run_process(argv, po);
  if (r.signal) {
    log << "capsflow: flow: interrupted (signal " << r.signal << ") while drawing " << p.png.string() << " (not drawn; "
        << p.h5.string() << " and " << p.xdmf.string() << " are written)\n";
    return 128 + r.signal;
  }
  if (!r.started || r.status != 0) {
    log << "capsflow: error: " << p.png.string() << " not drawn (" << py.python << " " << script.string()
        << " failed; " << p.h5.string() << " and " << p.xdmf.string() << " are written)\n";
    return 1;
  }
  if (!o.quiet) log << "  picture  " << p.png.string() << "\n";
  return 0;
}

}  // namespace

CLI::App* add_flow(CLI::App& app, FlowCommandOptions& o) {
  CLI::App* f = app.add_subcommand(
      "flow", "The fluid velocity of a run's frame on a plane's grid or at given points, by the solver's own "
              "operator (imposed flow + the membranes' single layer + the slit walls; the double layer at a "
              "viscosity ratio != 1): FLOW.h5 + FLOW.xdmf (ParaView) and FLOW.png");
  const CLI::Validator non_empty(
      [](std::string& v) { return v.empty() ? std::string("expected a non-empty value, got an empty string") : ""; },
      "", "non-empty");
  f->add_option("RUN.h5", o.run, "A run's output")->required()->check(non_empty)->type_name("RUN.h5");
  f->add_option_function<long>(
       "--frame", [&o](const long& n) { o.frame = n; }, "The frame (0 the first, -1 the last; default: the last)")
      ->type_name("N");
  CLI::Option_group* where = f->add_option_group("where", "Where to evaluate (one of)");
  const CLI::Validator plane_syntax(
      [](std::string& v) {
        char* end = nullptr;
        const bool ok = v.size() > 2 && (v[0] == 'x' || v[0] == 'y' || v[0] == 'z') && v[1] == '=' &&
                        std::isfinite(std::strtod(v.c_str() + 2, &end)) && end != v.c_str() + 2 && *end == '\0';
        return ok ? std::string() : "expected x=V, y=V or z=V with V a finite number, got '" + v + "'";
      },
      "", "AXIS=V");
  where->add_option("--plane", o.plane, "A plane of the box: x=V, y=V or z=V (lengths in a)")
      ->check(plane_syntax)
      ->type_name("AXIS=V");
  where->add_option("--points", o.points, "Points from a CSV file with header x,y,z (0 <= y <= H)")
      ->check(non_empty)
      ->type_name("FILE.csv");
  where->require_option(1);
  const CLI::Validator finite_positive(
      [](std::string& v) {
        char* end = nullptr;
        const double x = std::strtod(v.c_str(), &end);
        const bool ok = !v.empty() && *end == '\0' && std::isfinite(x) && x > 0.0;
        return ok ? std::string() : "expected a finite number > 0, got '" + v + "'";
      },
      "", "finite > 0");
  f->add_option("--spacing", o.spacing, "Grid step on the plane (a; the box's extents in whole steps)")
      ->check(finite_positive)
      ->capture_default_str();
  f->add_option("--out", o.out, "Output FLOW.h5 (FLOW.xdmf and, for a plane, FLOW.png beside it)")
      ->required()
      ->check(non_empty)
      ->type_name("FLOW.h5");
  f->add_option_function<std::string>(
       "--backend", [&o](const std::string& b) { o.backend = b; }, "serial | threads (default: the run's)")
      ->check(CLI::IsMember({"serial", "threads"}))
      ->type_name("B");
  f->add_option_function<int>(
       "--threads", [&o](const int& n) { o.threads = n; }, "OpenMP threads for 'threads' (0: the default)")
      ->check(CLI::NonNegativeNumber)
      ->type_name("N");
  f->add_flag("--force", o.force, "Replace existing output files");
  f->add_flag("-q,--quiet", o.quiet, "No summary");
  f->footer("Example:\n  capsflow flow run.h5 --plane z=3.1 --out flow.h5\n"
            "Exit status: 0 written, 2 input error (one line; nothing written), 1 internal error.");
  return f;
}

int run_flow(const FlowCommandOptions& o, std::ostream& log) {
  // Every input first: the frame, the configuration, the points, the outputs; then the work, then the files.
  const FlowPaths p = flow_paths(o);
  TargetPoints points;
  if (!o.points.empty()) points = read_targets_csv(o.points);
  const FrameStart f = read_frame_start(o.run, o.frame, "");
  const Config cfg = flow_config(f, o, log);
  FlowTargets t = o.points.empty() ? plane_targets(cfg, o.plane, o.spacing)
                                   : point_targets(std::move(points), cfg.domain.H, o.points);
  const auto t0 = std::chrono::steady_clock::now();
  const FlowField u = frame_flow(f, cfg, std::move(t));
  const double seconds = seconds_since(t0);
  write_flow_h5(p.h5, u, f, cfg);
  write_flow_xdmf(p.xdmf, p.h5, u);
  if (!o.quiet) {
    log << "capsflow flow: " << o.run << " frame " << f.frame << " (strain " << f.strain << "): " << u.at.size()
        << " points";
    if (!u.at.plane.empty()) log << " on the plane " << u.at.plane << " (" << u.at.nu << " x " << u.at.nv << ")";
    if (u.nodes_matched > 0) log << ", " << u.nodes_matched << " of them membrane nodes";
    log << " in " << seconds << " s\n  data     " << p.h5.string() << "\n  ParaView " << p.xdmf.string() << "\n";
  }
  return u.at.plane.empty() ? 0 : draw_picture(p, o, log);
}

}  // namespace capsflow
