// The implementation of figures_command.hpp: `capsflow figures`, which runs tools/capsflow_figures.py.
#include "host/cli/figures_command.hpp"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <system_error>

#include "host/base/errors.hpp"
#include "host/base/h5_file.hpp"
#include "host/cli/subprocess.hpp"

namespace capsflow {
namespace {

namespace fs = std::filesystem;

constexpr const char* kScriptName = "capsflow_figures.py";
constexpr const char* kInstallHint =
    "on Debian: apt-get install python3-matplotlib python3-h5py (or set CAPSFLOW_PYTHON to a python3 that has them)";

// Runs argv (no shell) and waits. capture: its stdout is returned and its stderr discarded; otherwise it shares ours.
ProcessResult spawn_and_wait(const std::vector<std::string>& argv, bool capture) {
  ProcessOptions o;
  o.capture_stdout = capture;
  o.discard_stderr = capture;
  o.own_group = true;  // matplotlib ends with capsflow, whatever ends it (subprocess.hpp)
  return run_process(argv, o);
}

std::string trim(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ' || s.back() == '\r')) s.pop_back();
  return s;
}

fs::path executable_dir() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return {};
  return exe.parent_path();
}

void check_analysis_dir(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw InputError(dir + ": not a directory (expected an analysis directory holding analysis.h5)");
  const fs::path file = fs::path(dir) / "analysis.h5";
  if (!fs::is_regular_file(file, ec))
    throw InputError(dir + ": no analysis.h5 in this directory (write it with capsflow analyze)");
  const H5File h5 = H5File::open(file);  // InputError if it is not HDF5
  std::string format;
  try {
    if (h5.has_attribute("/", "format")) format = h5.attribute<std::string>("/", "format");
  } catch (const H5Error&) {
    format = "<not a string>";
  }
  if (format != "capsflow-analysis")
    throw InputError(file.string() + ": not a capsflow analysis file (attribute format = '" + format +
                     "', expected 'capsflow-analysis')");
}

}  // namespace

// A run output (OUT.h5) to draw the run's diagnostics from: an HDF5 file with the run's configuration and capsules,
// not its checkpoint (which holds a state, not series) and not an analysis.
void check_run_output(const std::string& path) {
  const H5File h5 = H5File::open(path);  // InputError if it is not HDF5
  if (h5.exists("/state") && h5.exists("/run")) {
    std::string of;
    if (h5.has_attribute("/", "output_file")) of = " (" + fs::path(h5.attribute<std::string>("/", "output_file")).filename().string() + " beside it)";
    throw InputError(path + ": a checkpoint, not a run output: draw the run's output" + of);
  }
  if (h5.has_attribute("/", "format"))
    throw InputError(path + ": an analysis file: give its directory (capsflow figures ANALYSIS_DIR)");
  if (!h5.exists("/parameters/config") || !h5.exists("/capsules/species"))
    throw InputError(path + ": not a capsflow run output (no /parameters/config or /capsules/species); expected "
                     "an ANALYSIS_DIR or a run's OUT.h5");
}

FiguresPython find_figures_python() {
  // find_spec does not import: the probe takes a few tens of milliseconds, not the second matplotlib needs.
  static const char* const kProbe =
      "import importlib.util as u, sys\n"
      "m = [n for n in ('numpy', 'matplotlib', 'h5py') if u.find_spec(n) is None]\n"
      "print(', '.join(m))\n"
      "sys.exit(1 if m else 0)\n";
  std::vector<std::pair<std::string, std::string>> candidates;  // (program, how it was chosen)
  const char* env = std::getenv("CAPSFLOW_PYTHON");
  if (env && *env) {
    candidates.emplace_back(env, std::string("CAPSFLOW_PYTHON=") + env);
  } else {
    // The system interpreter first: Debian's python3-matplotlib and python3-h5py install there, while a python3
    // earlier on PATH (pyenv, a venv) often lacks them.
    candidates.emplace_back("/usr/bin/python3", "/usr/bin/python3");
    candidates.emplace_back("python3", "python3 on PATH");
  }
  FiguresPython result;
  std::string tried;
  for (const auto& [program, what] : candidates) {
    const ProcessResult s = spawn_and_wait({program, "-c", kProbe}, true);
    if (s.signal) {  // stopped from outside while probing: nothing written yet
      std::cerr << "capsflow figures: interrupted (signal " << s.signal << ") before drawing; nothing was written\n";
      std::exit(128 + s.signal);
    }
    std::string outcome;
    if (!s.started) {
      outcome = std::string("cannot run (") + std::strerror(s.error) + ")";
    } else if (s.status == 0) {
      result.python = program;
      return result;
    } else if (s.status == 1 && !trim(s.out).empty()) {
      outcome = "no module " + trim(s.out);
    } else {
      outcome = "probe failed (exit status " + std::to_string(s.status) + ")";
    }
    tried += (tried.empty() ? "" : "; ") + what + ": " + outcome;
  }
  result.problem = "capsflow figures needs python3 with numpy, matplotlib and h5py (" + tried + "); " + kInstallHint;
  return result;
}

fs::path find_share_script(const std::string& name, const std::string& command) {
  const fs::path dir = executable_dir();
  if (dir.empty())
    throw InputError(command + ": cannot find the directory of the running executable (/proc/self/exe), so not the "
                     "script share/capsflow/" + name + " either");
  const fs::path candidates[] = {dir / "share" / "capsflow" / name, dir.parent_path() / "share" / "capsflow" / name};
  std::error_code ec;
  for (const fs::path& p : candidates)
    if (fs::is_regular_file(p, ec)) return p;
  throw InputError(command + ": the script " + name + " is missing: looked for " +
                   candidates[0].lexically_normal().string() + " (build tree) and " +
                   candidates[1].lexically_normal().string() + " (installed); rebuild (cmake copies tools/" + name +
                   " there) or reinstall");
}

fs::path find_figures_script() { return find_share_script(kScriptName, "capsflow figures"); }

int run_figures(const std::vector<std::string>& dirs, const std::string& out, bool force, const std::string& only) {
  if (dirs.empty()) throw InputError("capsflow figures: give at least one ANALYSIS_DIR or RUN.h5");
  for (const std::string& d : dirs) {
    std::error_code dir_ec;
    if (fs::is_directory(d, dir_ec))
      check_analysis_dir(d);
    else if (fs::is_regular_file(d, dir_ec))
      check_run_output(d);
    else
      throw InputError(d + ": no such directory or file (expected an ANALYSIS_DIR holding analysis.h5 or a run's "
                       "OUT.h5)");
  }
  std::error_code ec;
  if (fs::exists(out, ec) && !fs::is_directory(out, ec))
    throw InputError("--out " + out + ": exists and is not a directory");

  const fs::path script = find_figures_script();
  const FiguresPython py = find_figures_python();
  if (py.python.empty()) throw InputError(py.problem);

  std::vector<std::string> argv = {py.python, script.string(), "--out", out};
  if (force) argv.emplace_back("--force");
  if (!only.empty()) argv.insert(argv.end(), {"--only", only});
  argv.emplace_back("--");  // directories that start with '-' stay positional
  argv.insert(argv.end(), dirs.begin(), dirs.end());
  const ProcessResult s = spawn_and_wait(argv, false);
  if (!s.started)
    throw InputError("capsflow figures: cannot run " + py.python + " (" + std::strerror(s.error) + ")");
  if (s.signal) {
    // The drawing was ended with us (its group): each figure it had finished is whole (written atomically).
    std::cerr << "capsflow figures: interrupted (signal " << s.signal << "); the figures already written are whole\n";
    return 128 + s.signal;
  }
  return s.status;
}

}  // namespace capsflow
