#pragma once
// The configuration of `capsflow run` without a config file (the README's demo): a few capsules of two species in
// Poiseuille flow.
#include <string>

namespace capsflow {

std::string embedded_demo_config();

}  // namespace capsflow
