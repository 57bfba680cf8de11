// Reading the run configuration (config.hpp; every key is listed in docs/usage.md).
//
// The parser is table-driven so that a new section costs one reader function and one row in kSections:
//
//   SectionReader r(root, "domain", source);     // a view of one [section]
//   geo.H = r.number("H", Req{}, positive);      // typed key: required, or with a default; a range check
//   r.finish();                                  // any key that no reader asked for is an error
//
// Every error is one line, "<file>: [section] key: expected <what>, got <what>", thrown as InputError, so the
// command line can print it as is. Integers are accepted where a number is expected (H = 4 means 4.0); a
// float where an integer is expected is an error rather than a silent truncation.
#include "host/config.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <optional>
#include <sstream>
#include <string_view>
#include <toml++/toml.h>
#include <utility>
#include <vector>

#include "host/backend_select.hpp"
#include "host/errors.hpp"

namespace capsflow {
namespace {

// Shortest text that reads back as the same double ("2", "0.1", "1e-09").
std::string fmt(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  std::array<char, 64> buf{};
  auto res = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  return std::string(buf.data(), res.ptr);
}

// One line: newlines inside a message (toml++ descriptions, user strings) would break the one-line contract.
std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

// How a TOML value is named after "got": its type, and the value itself where it is short.
std::string describe(const toml::node& n) {
  if (auto v = n.as_integer()) return "integer " + std::to_string(v->get());
  if (auto v = n.as_floating_point()) {
    std::string t = fmt(v->get());
    if (t.find_first_of(".eni") == std::string::npos) t += ".0";  // a float that looks like one: "16.0"
    return "float " + t;
  }
  if (auto v = n.as_boolean()) return std::string("boolean ") + (v->get() ? "true" : "false");
  if (auto v = n.as_string()) return "string \"" + one_line(v->get()) + "\"";
  if (n.is_array()) return "an array";
  if (n.is_table()) return "a table";
  if (n.is_date()) return "a date";
  if (n.is_time()) return "a time";
  if (n.is_date_time()) return "a date-time";
  return "an unsupported value";
}

// A range check: `ok` tells whether a value is accepted, `what` says what is expected ("> 0").
struct Range {
  std::function<bool(double)> ok;
  std::string what;
};
Range any_number() { return {[](double) { return true; }, ""}; }
Range positive() { return {[](double v) { return v > 0.0; }, "> 0"}; }
Range at_least(double lo) { return {[lo](double v) { return v >= lo; }, ">= " + fmt(lo)}; }
Range in_half_open(double lo, double hi) {  // lo < v <= hi
  return {[lo, hi](double v) { return v > lo && v <= hi; }, "in (" + fmt(lo) + ", " + fmt(hi) + "]"};
}

// A view of one [section] of the document that hands out typed keys and remembers which it handed out.
class SectionReader {
 public:
  SectionReader(const toml::table* table, std::string section, std::string source)
      : table_(table), section_(std::move(section)), source_(std::move(source)) {}

  // A floating-point key (integers accepted). Absent: the default, or an error when it is required.
  double number(std::string_view key, std::optional<double> dflt, const Range& range = any_number()) {
    auto v = optional_number(key, range);
    if (v) return *v;
    if (!dflt) missing(key, expect_number(range));
    return *dflt;
  }

  std::optional<double> optional_number(std::string_view key, const Range& range = any_number()) {
    const toml::node* n = lookup(key);
    if (!n) return std::nullopt;
    double v = 0.0;
    if (auto i = n->as_integer()) {
      v = static_cast<double>(i->get());
    } else if (auto f = n->as_floating_point()) {
      v = f->get();
    } else {
      fail(key, expect_number(range), describe(*n));
    }
    if (!std::isfinite(v) || !range.ok(v)) fail(key, expect_number(range), describe(*n));
    return v;
  }

  // An integer key (a float, even 8.0, is an error). Absent: the default, or an error when it is required.
  int integer(std::string_view key, std::optional<int> dflt, const Range& range = any_number()) {
    auto v = optional_integer(key, range);
    if (v) return *v;
    if (!dflt) missing(key, expect_integer(range));
    return *dflt;
  }

  std::optional<int> optional_integer(std::string_view key, const Range& range = any_number()) {
    const toml::node* n = lookup(key);
    if (!n) return std::nullopt;
    auto i = n->as_integer();
    if (!i) fail(key, expect_integer(range), describe(*n));
    const std::int64_t v = i->get();
    if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max() ||
        !range.ok(static_cast<double>(v)))
      fail(key, expect_integer(range), describe(*n));
    return static_cast<int>(v);
  }

  // A string key that must be one of `choices`.
  std::string choice(std::string_view key, const std::string& dflt, const std::vector<std::string>& choices) {
    std::string what = "one of";
    for (std::size_t i = 0; i < choices.size(); ++i) what += (i ? ", \"" : " \"") + choices[i] + "\"";
    const toml::node* n = lookup(key);
    if (!n) return dflt;
    auto s = n->as_string();
    if (!s) fail(key, what, describe(*n));
    for (const auto& c : choices)
      if (s->get() == c) return c;
    fail(key, what, describe(*n));
  }

  // Rejects every key of the section that no reader asked for.
  void finish() const {
    if (!table_) return;
    for (const auto& [k, v] : *table_) {
      if (std::find(asked_.begin(), asked_.end(), k.str()) != asked_.end()) continue;
      std::string known;
      for (const auto& a : asked_) known += (known.empty() ? "" : ", ") + a;
      fail(k.str(), "one of the keys of [" + section_ + "] (" + known + ")",
           "unknown key '" + one_line(std::string(k.str())) + "'");
    }
  }

 private:
  const toml::node* lookup(std::string_view key) {
    if (std::find(asked_.begin(), asked_.end(), key) == asked_.end()) asked_.emplace_back(key);
    return table_ ? table_->get(key) : nullptr;
  }
  static std::string expect_number(const Range& r) {
    return r.what.empty() ? "a finite number" : "a finite number " + r.what;
  }
  static std::string expect_integer(const Range& r) { return r.what.empty() ? "an integer" : "an integer " + r.what; }
  [[noreturn]] void fail(std::string_view key, const std::string& expected, const std::string& got) const {
    throw InputError(source_ + ": [" + section_ + "] " + one_line(std::string(key)) + ": expected " + expected +
                     ", got " + got);
  }
  [[noreturn]] void missing(std::string_view key, const std::string& expected) const {
    fail(key, expected, "nothing (this key is required)");
  }

  const toml::table* table_;  // null when the section is absent: every key takes its default
  std::string section_;
  std::string source_;
  std::vector<std::string> asked_;  // in the order the reader asked: how they are listed in messages
};

// ----------------------------------------------------------------------------------------------------------
// One reader per section. Cross-checks between keys of different sections run after all sections are read.

void read_domain(SectionReader& r, Config& c) {
  c.domain.H = r.number("H", std::nullopt, positive());
  c.domain.Lx = r.number("Lx", std::nullopt, positive());
  c.domain.Lz = r.number("Lz", std::nullopt, positive());
  c.domain.viscosity = r.number("viscosity", 1.0, positive());
}

void read_ggem(SectionReader& r, Config& c) {
  GgemOptions& g = c.ggem;
  g.alpha = r.number("alpha", 4.0, positive());
  g.alpha_hm = r.number("alpha_hm", 0.5, in_half_open(0.0, 2.0));
  g.nx = r.integer("nx", 0, at_least(8));
  g.nz = r.integer("nz", 0, at_least(8));
  g.ny = r.integer("ny", 0, at_least(8));
  g.cutoff = r.number("cutoff", 4.0 / g.alpha, positive());
  g.chebyshev_rule = r.choice("chebyshev_rule", "midchannel", {"midchannel", "mean"});
}

void read_run(SectionReader& r, Config& c) {
  c.run.backend = parse_backend(r.choice("backend", "serial", {"serial", "threads", "device"}), "[run] backend");
  c.run.threads = r.integer("threads", 0, at_least(0));
}

struct SectionSpec {
  const char* name;
  void (*read)(SectionReader&, Config&);
};

// The known sections, in the order they are read (and listed in error messages).
// Next: [flow], [capsules], [[species]], [suspension], [[capsule]], [time], [output].
constexpr SectionSpec kSections[] = {
    {"domain", read_domain},
    {"ggem", read_ggem},
    {"run", read_run},
};

// Checks across keys, once every section is read. The message names the key the user is most likely to change.
void check_period_fits_cutoff(const std::string& source, const char* key, double L, double cutoff) {
  // The local sum sees each source at most once per period (minimum image): r_c <= L / 2.
  if (L >= 2.0 * cutoff) return;
  throw InputError(source + ": [domain] " + key + ": " + key + " = " + fmt(L) + " is too small for the cutoff " +
                   fmt(cutoff) + ": need " + key + " >= 2 * cutoff = " + fmt(2.0 * cutoff));
}

void cross_check(const Config& c) {
  check_period_fits_cutoff(c.source, "Lx", c.domain.Lx, c.ggem.cutoff);
  check_period_fits_cutoff(c.source, "Lz", c.domain.Lz, c.ggem.cutoff);
}

}  // namespace

Config parse_config(const std::string& text, const std::string& source_name) {
  toml::table root;
  try {
    root = toml::parse(text, source_name);
  } catch (const toml::parse_error& e) {
    const auto& where = e.source().begin;
    throw InputError(source_name + ":" + std::to_string(where.line) + ":" + std::to_string(where.column) +
                     ": invalid TOML: " + one_line(std::string(e.description())));
  }

  std::string known;
  for (const auto& s : kSections) known += std::string(known.empty() ? "" : ", ") + "[" + s.name + "]";
  for (const auto& [k, v] : root) {
    const std::string name(k.str());
    bool is_known = false;
    for (const auto& s : kSections) is_known = is_known || name == s.name;
    if (!is_known)
      throw InputError(source_name + ": [" + one_line(name) + "]: expected one of the sections " + known +
                       ", got unknown " + (v.is_table() ? "section" : "top-level key") + " '" + one_line(name) +
                       "'");
    if (!v.is_table())
      throw InputError(source_name + ": [" + name + "]: expected a table [" + name + "], got " + describe(v));
  }

  Config c;
  c.source = source_name;
  for (const auto& s : kSections) {
    SectionReader r(root[s.name].as_table(), s.name, source_name);
    s.read(r, c);
    r.finish();
  }
  cross_check(c);
  return c;
}

Config load_config(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the config file: " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(path + ": cannot read the config file");
  return parse_config(text.str(), path);
}

}  // namespace capsflow
