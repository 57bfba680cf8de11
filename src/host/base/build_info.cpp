// The build's description (build_info.hpp): the version, the sources' commit CMake stamps at every build, the compiler.
#include "host/base/build_info.hpp"

// The only includer of the generated header: a new commit recompiles this file alone.
#include "capsflow_build_commit.hpp"
#include "capsflow_version.hpp"

namespace capsflow {

const char* build_commit() { return CAPSFLOW_BUILD_COMMIT; }

std::string build_description() {
  return std::string("capsflow ") + CAPSFLOW_VERSION_STRING + " (commit " + CAPSFLOW_BUILD_COMMIT + ")";
}

}  // namespace capsflow
