#pragma once
// Which build this is: the version and the commit of the sources it was built from ("<hash>", "<hash>-dirty" when
// tracked files differed from it, "unknown" outside a git checkout). Runs log it at every start and continuation
// (the sweep's run.log), so a run continued across builds says which build ran which strain.
#include <string>

namespace capsflow {

const char* build_commit();
// "capsflow 0.1.0 (commit 86ce0db1a2b3)"
std::string build_description();

}  // namespace capsflow
