#pragma once
// `capsflow analyze RUN.h5|DIR ... --out DIR [--window T0:T1] [--bins N] [--force]`: the study's analysis
// (docs/analysis.md) over any number of run outputs, written as DIR/analysis.h5 (what
// `capsflow figures` draws), DIR/summary.json and CSV tables.
//
// What it does:
//   1. loads every run (a directory is searched recursively for run outputs; checkpoints are skipped) with
//      read_run_file, which reads files that a live run is still writing;
//   2. classifies each run from its configuration: "pinned" (every capsule pinned: an isolated migration run),
//      "pair" (two capsules in shear: a pair collision), otherwise "suspension";
//   3. groups suspension runs by their physics (box, capsule count, species counts and Ca; seed, end, backend,
//      threads and file names do not split a group): realizations in a group are pooled. Groups of one "set" (the
//      same box, count and [[species]] Ca values) that differ only in the species fractions give the curves
//      against X_f (d-bar, E, f_AB). Pinned runs of the same box give the isolated V^S(y) curves (S*, F*);
//   4. computes every quantity of docs/analysis.md §5-§12 with the analysis library and writes the files.
//
// Default window: the last 1000 strain units, or the second half of a shorter run (said in the output). Refused
// (exit 2, before any file is written): no run found, an existing --out without --force, a window outside a run,
// mixed boxes in one group, one run given twice (the same run id, the root attribute run_id: a file named twice, a
// directory and a file in it, or a copy; the message names both paths). Flagged, not refused: a capsule whose volume
// strayed beyond 1e-3 of its initial value.
//
// Outputs are staged under hidden temporary names and renamed into place only when all are complete; a failure
// (a full disk: exit 1) removes the temporaries, the outputs already renamed and the directories the analysis
// created, so that nothing blocks the rerun and an earlier analysis is replaced only by a complete one.
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

namespace capsflow {

struct AnalyzeOptions {
  std::vector<std::string> inputs;     // run files or directories
  std::string out;                     // output directory
  std::optional<double> t0, t1;        // --window T0:T1
  int bins = 25;                       // --bins: folded bins over [0, H/2]
  bool force = false;                  // replace an existing output directory's files
  bool quiet = false;
};

// Parses "T0:T1" (InputError naming --window otherwise).
void parse_window(const std::string& text, AnalyzeOptions& o);

// Runs the analysis; returns the exit status (0). Throws InputError for bad input.
int run_analyze(const AnalyzeOptions& o, std::ostream& log);

}  // namespace capsflow
