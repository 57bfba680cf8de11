#pragma once
// `capsflow demo`: a few seconds of GGEM on point forces between the walls (the velocity profile of one force against
// the free-space Stokeslet, and the cost of one velocity evaluation in the set-A box), written to profile.csv. The
// README's first command, the capsule demo, is `capsflow run` without CONFIG (tools/demo.sh).
#include <string>

namespace capsflow {

// Runs the demo, writes its files under out_dir (created; an existing non-empty directory is an InputError unless
// overwrite) and prints a summary. Returns the exit status.
int run_demo(const std::string& out_dir, bool overwrite, int threads);

}  // namespace capsflow
