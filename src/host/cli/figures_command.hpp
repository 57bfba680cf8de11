#pragma once
// `capsflow figures ANALYSIS_DIR|RUN.h5... --out FIGDIR [--force]`: draws the figures of the segregation study from
// the analysis.h5 files that `capsflow analyze` writes, and a run's diagnostics from its OUT.h5 (docs/usage.md,
// "capsflow figures"): one plotting stack, matplotlib.
//
// The drawing is a Python script (tools/capsflow_figures.py, matplotlib + h5py); this side finds the script and a
// python3 that can run it, checks the input cheaply, then runs the script (no shell) and returns its exit status.
//
// Where the script is looked for, in this order (the first that exists wins):
//   1. <directory of the running executable>/share/capsflow/capsflow_figures.py   the build tree: CMake copies
//      tools/capsflow_figures.py there when it configures;
//   2. <directory of the running executable>/../share/capsflow/capsflow_figures.py   the installed layout
//      (bin/capsflow, share/capsflow/capsflow_figures.py: `cmake --install`).
// Which python3: $CAPSFLOW_PYTHON if set (and only that), else /usr/bin/python3 (the Debian interpreter, whose
// packages python3-matplotlib and python3-h5py are the documented way to get the modules), else `python3` on PATH (a
// python3 earlier on PATH, e.g. a pyenv or venv one, often lacks them, so it comes second).
//
// Usage (src/host/cli/main.cpp):
//   return run_figures(dirs, out, force);   // 0 drawn (or nothing to draw), 2 input error, 1 a figure failed
#include <filesystem>
#include <string>
#include <vector>

namespace capsflow {

// A python3 that has numpy, matplotlib and h5py (`python` empty if none: `problem` then says what was tried and
// which Debian packages to install, in one line).
struct FiguresPython {
  std::string python;
  std::string problem;
};
FiguresPython find_figures_python();

// The script by the search order above. InputError naming the paths searched if it is in neither place.
std::filesystem::path find_figures_script();
// The same search for any script installed beside it (capsflow_render.py); `command` names the caller in the error.
std::filesystem::path find_share_script(const std::string& name, const std::string& command);

// InputError unless `path` is a run output OUT.h5 (an HDF5 file with /parameters/config and /capsules/species), naming
// what it is instead (a checkpoint, an analysis file, another HDF5 file).
void check_run_output(const std::string& path);

// Checks the arguments (each directory holds an analysis.h5 of format "capsflow-analysis"; --out is not an existing
// file), finds the script and python3, and runs the script with the same arguments. Returns the script's exit
// status (128 + signal if it was killed). InputError for bad input, a missing script or a python3 without the
// modules; the script reports the rest itself (an existing figure without --force: status 2, one line).
// only: the study's figures to draw, comma-separated (empty: all); the script refuses an unknown name.
int run_figures(const std::vector<std::string>& dirs, const std::string& out, bool force,
                const std::string& only = "");

}  // namespace capsflow
