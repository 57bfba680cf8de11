#pragma once
// The reader of the run configuration (config.hpp): typed access to one TOML [section], and the words of its
// messages. Used by the section readers (config_schema.cpp), the document level (config.cpp) and the checks across
// keys (config_checks.cpp); other code uses parse_config / resolve_config.
//
//   SectionReader r(table, "domain", source);              // a view of one [section]
//   geo.H = r.number("H", std::nullopt, positive());       // typed key: required, or with a default; a range check
//   r.finish();                                            // any key that no reader asked for is an error
//
// Every error is one line, "<file>: [section] key: expected <what>, got <what>", thrown as InputError, so the
// command line can print it as is. Integers are accepted where a number is expected (H = 4 means 4.0); a
// float where an integer is expected is an error rather than a silent truncation.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <toml++/toml.h>
#include <vector>

#include "host/physics/config.hpp"
#include "host/physics/config_schema.hpp"
#include "host/physics/config_toml.hpp"

namespace capsflow::config_detail {

// Shortest text that reads back as the same double ("2", "0.1", "1e-09").
std::string fmt(double v);

// One line: newlines inside a message (toml++ descriptions, user strings) would break the one-line contract.
std::string one_line(std::string s);

// How a TOML value is named after "got": its type, and the value itself where it is short.
std::string describe(const toml::node& n);

// The first line of to_toml's text (a run's stored config); resolve_config reads such text as capsflow's own.
inline constexpr const char* kResolvedHeader = "# Resolved configuration (every key, defaults filled in)";

// A range check: `ok` tells whether a value is accepted, `what` says what is expected ("> 0").
struct Range {
  std::function<bool(double)> ok;
  std::string what;
};
Range any_number();
Range positive();
Range at_least(double lo);
Range in_half_open(double lo, double hi);  // lo < v <= hi
Range in_open(double lo, double hi);       // lo < v < hi
Range in_closed(double lo, double hi);     // lo <= v <= hi

// While one lives, every typed accessor of every SectionReader records its key in `keys` (config_keys(), the
// describing mode), and a required key that is absent takes a placeholder instead of throwing, so that a reader goes
// on to its later keys. One at a time.
class SchemaRecording {
 public:
  explicit SchemaRecording(std::vector<ConfigKey>& keys);
  ~SchemaRecording();
  SchemaRecording(const SchemaRecording&) = delete;
  SchemaRecording& operator=(const SchemaRecording&) = delete;
};

// A view of one [section] of the document that hands out typed keys and remembers which it handed out.
class SectionReader {
 public:
  // `label` is how messages name the section: "[domain]" by default, "[[species]] 2" for an array element.
  // `origins`: the keys of this table that an override set, and how messages name them ("--set suspension.seed").
  SectionReader(const toml::table* table, std::string section, std::string source, std::string label = "",
                const OverrideOrigins* origins = nullptr);

  bool present() const { return table_ != nullptr; }

  // Whether the input wrote `key` (not its default). In capsflow's own resolved text (a run's stored config, where
  // every key is written) only an override counts: its keys' presence says nothing about what the user chose.
  bool given(std::string_view key);
  void set_stored(bool stored) { stored_ = stored; }

  // A floating-point key (integers accepted). Absent: the default, or an error when it is required.
  double number(std::string_view key, std::optional<double> dflt, const Range& range = any_number());
  std::optional<double> optional_number(std::string_view key, const Range& range = any_number());

  // An integer key (a float, even 8.0, is an error). Absent: the default, or an error when it is required.
  int integer(std::string_view key, std::optional<int> dflt, const Range& range = any_number());
  std::optional<int> optional_integer(std::string_view key, const Range& range = any_number());

  // A 64-bit integer key (seeds, counts).
  std::optional<std::int64_t> optional_int64(std::string_view key, const Range& range = any_number());

  // A string key (non-empty when `nonempty`). Absent: the default, or an error when it is required.
  std::string string(std::string_view key, std::optional<std::string> dflt, bool nonempty = true);

  bool boolean(std::string_view key, bool dflt);

  // An array of finite numbers (integers accepted), each in `range`; `length` > 0 fixes the length, otherwise at
  // least one element. Absent: nullopt, or an error when `required`.
  std::optional<std::vector<double>> numbers(std::string_view key, bool required, std::size_t length = 0,
                                             const Range& range = any_number());

  // A string key that must be one of `choices`.
  std::string choice(std::string_view key, const std::string& dflt, const std::vector<std::string>& choices);

  // An error about a combination of keys, reported at `key`.
  [[noreturn]] void conflict(std::string_view key, const std::string& expected, const std::string& got) const {
    fail(key, expected, got);
  }

  // Rejects every key of the section that no reader asked for.
  void finish() const;

 private:
  void describe_key(std::string_view key, const char* type, const std::string& expected, bool required,
                    std::function<bool(double)> accepts = {}, std::vector<std::string> choices = {},
                    std::size_t length = 0) const;
  const toml::node* lookup(std::string_view key);
  [[noreturn]] void fail(std::string_view key, const std::string& expected, const std::string& got) const;
  [[noreturn]] void missing(std::string_view key, const std::string& expected) const;

  const toml::table* table_;  // null when the section is absent: every key takes its default
  std::string section_;
  std::string source_;
  std::string label_;
  const OverrideOrigins* origins_;
  bool stored_ = false;             // reading capsflow's resolved text (to_toml), not a user's file
  std::vector<std::string> asked_;  // in the order the reader asked: how they are listed in messages
};

// One known section: its name and its reader (config_schema.cpp).
struct SectionSpec {
  const char* name;
  void (*read)(SectionReader&, Config&);
  bool array = false;  // an array of tables [[name]]: read is called once per element
};

// The known sections, in the order they are read (and listed in error messages).
const std::vector<SectionSpec>& config_sections();

}  // namespace capsflow::config_detail
