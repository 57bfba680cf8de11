#pragma once
// Error types shared by the whole host code.
//
// InputError is everything the user can fix (a malformed config, a bad CSV row, a capsule outside the slit):
// the command line prints its message on one line and exits with status 2. Anything else that escapes is a
// bug or an environment problem and exits with status 1.
#include <stdexcept>
#include <string>

namespace capsflow {

struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A backend that was asked for but is not built into this binary or has no device to run on.
struct BackendUnavailable : InputError {
  using InputError::InputError;
};

}  // namespace capsflow
