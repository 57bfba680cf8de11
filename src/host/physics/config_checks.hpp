#pragma once
// The checks of the run configuration across keys (config.hpp says which run where): what one key's range cannot
// tell. Each refusal is one line, "<origin>: <what was expected>, got <what>", thrown as InputError; the origin is
// the file and key, or the override that set the key (Config::origin). Used by read_config (config.cpp), to_toml
// (config_schema.cpp) and validate_run_config.
#include <string>

#include "host/physics/config.hpp"

namespace capsflow::config_detail {

// Throws InputError "<origin of where>: <what>".
[[noreturn]] void run_error(const Config& c, const std::string& where, const std::string& what);

// Every species a drop (law = "surface-tension", its own or [capsules]'), so that no capsule uses [capsules]
// inflation; with no species, [capsules] law decides.
bool every_species_a_drop(const Config& c);

// A [capsules] inflation written for drops only: a drop has no reference state, the key would do nothing.
void check_drop_inflation(const Config& c);

// The periods against the local cutoff, and the grid's size (sizes beyond int would wrap silently).
void cross_check(const Config& c);

// The run sections: one placement, unique species names, the stop rules' problem shape, reference_ca, fractions,
// capsule species; and once capsules are defined, the box against them and the explicit capsules' positions.
void check_run_sections(const Config& c);

}  // namespace capsflow::config_detail
