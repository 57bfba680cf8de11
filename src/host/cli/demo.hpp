#pragma once
// The embedded demo behind 'capsflow demo' (the README's first command): a few seconds of GGEM on built-in
// configurations, written to a directory with a plot.
#include <string>

namespace capsflow {

// Runs the demo, writes its files under out_dir (created; an existing non-empty directory is an InputError unless
// overwrite) and prints a summary. Returns the exit status.
int run_demo(const std::string& out_dir, bool overwrite, int threads);

}  // namespace capsflow
