#pragma once
// The TOML level of the configuration (config.hpp): overrides applied to a parsed document, and the reading of a
// document into a Config. For callers that hold a toml::table; the others use parse_config / resolve_config.
//
//   toml::table root = toml::parse(text);
//   const AppliedOverrides applied = apply_overrides(root, overrides, "run.toml");   // errors name the override
//   Config c = read_config(root, "run.toml", applied);                             // every key checked
#include <map>
#include <string>
#include <toml++/toml.h>
#include <utility>
#include <vector>

#include "host/physics/config.hpp"

namespace capsflow {

// (table, key) -> how messages name a key that an override set ("--set species.2.ca").
using OverrideOrigins = std::map<std::pair<const toml::table*, std::string>, std::string>;

struct AppliedOverrides {
  OverrideOrigins keys;                       // for the section readers
  std::map<std::string, std::string> labels;  // "[[species]] 2 ca" -> "--set species.2.ca": for checks across keys
};

// Applies the overrides in order (syntax in config.hpp). A malformed key or value, or a section that does not exist,
// is an InputError naming the override, worded as the same mistake in the file would be.
AppliedOverrides apply_overrides(toml::table& root, const std::vector<ConfigOverride>& overrides,
                                 const std::string& source_name);

// Reads and checks every section of a document (parse_config without the parsing).
// `stored`: `root` is capsflow's own resolved text (to_toml), where every key is written: only overrides count as
// keys the user chose (SectionReader::given).
Config read_config(const toml::table& root, const std::string& source_name, const AppliedOverrides& applied = {},
                   bool stored = false);

// A stored configuration (a checkpoint's /parameters/config, a sweep point's config.toml) is continued with the
// rules of the build that wrote it where it lacks the key of a later default: no [time] step_rule -> the paper's
// rule (before issue 17); no [quadrature] table -> fine_quadrature(), the element rules before issue 34 (every build
// since writes the table). `stored` is the parsed text, `c` the configuration read from it.
void keep_earlier_build_rules(const toml::table& stored, Config& c);

}  // namespace capsflow
