// The reader of the run configuration (config_reader.hpp): SectionReader's typed keys and the words of the
// messages. What each section holds is config_schema.cpp; the document, overrides and entry points are config.cpp.
#include "host/physics/config_reader.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <limits>
#include <utility>

#include "host/base/errors.hpp"

namespace capsflow::config_detail {
namespace {

// Set while a SchemaRecording lives (config_keys()).
std::vector<ConfigKey>* g_schema = nullptr;

std::string expect_number(const Range& r) { return r.what.empty() ? "a finite number" : "a finite number " + r.what; }
std::string expect_integer(const Range& r) { return r.what.empty() ? "an integer" : "an integer " + r.what; }

}  // namespace

std::string fmt(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  std::array<char, 64> buf{};
  auto res = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  return std::string(buf.data(), res.ptr);
}

std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

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

Range any_number() { return {[](double) { return true; }, ""}; }
Range positive() { return {[](double v) { return v > 0.0; }, "> 0"}; }
Range at_least(double lo) { return {[lo](double v) { return v >= lo; }, ">= " + fmt(lo)}; }
Range in_half_open(double lo, double hi) {
  return {[lo, hi](double v) { return v > lo && v <= hi; }, "in (" + fmt(lo) + ", " + fmt(hi) + "]"};
}
Range in_open(double lo, double hi) {
  return {[lo, hi](double v) { return v > lo && v < hi; }, "in (" + fmt(lo) + ", " + fmt(hi) + ")"};
}
Range in_closed(double lo, double hi) {
  return {[lo, hi](double v) { return v >= lo && v <= hi; }, "in [" + fmt(lo) + ", " + fmt(hi) + "]"};
}

SchemaRecording::SchemaRecording(std::vector<ConfigKey>& keys) { g_schema = &keys; }
SchemaRecording::~SchemaRecording() { g_schema = nullptr; }

SectionReader::SectionReader(const toml::table* table, std::string section, std::string source, std::string label,
                             const OverrideOrigins* origins)
    : table_(table),
      section_(std::move(section)),
      source_(std::move(source)),
      label_(label.empty() ? "[" + section_ + "]" : std::move(label)),
      origins_(origins) {}

bool SectionReader::given(std::string_view key) {
  if (!lookup(key)) return false;
  return !stored_ || (origins_ && origins_->count({table_, std::string(key)}) > 0);
}

double SectionReader::number(std::string_view key, std::optional<double> dflt, const Range& range) {
  describe_key(key, "number", expect_number(range), !dflt, range.ok);
  auto v = optional_number(key, range);
  if (v) return *v;
  if (!dflt && g_schema) return 1.0;
  if (!dflt) missing(key, expect_number(range));
  return *dflt;
}

std::optional<double> SectionReader::optional_number(std::string_view key, const Range& range) {
  describe_key(key, "number", expect_number(range), false, range.ok);
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

int SectionReader::integer(std::string_view key, std::optional<int> dflt, const Range& range) {
  describe_key(key, "integer", expect_integer(range), !dflt, range.ok);
  auto v = optional_integer(key, range);
  if (v) return *v;
  if (!dflt && g_schema) return 1;
  if (!dflt) missing(key, expect_integer(range));
  return *dflt;
}

std::optional<int> SectionReader::optional_integer(std::string_view key, const Range& range) {
  auto v = optional_int64(key, range);
  if (!v) return std::nullopt;
  // The key is stored in an int: say the upper bound too, or "expected an integer >= 8" would refuse a value >= 8.
  if (*v < std::numeric_limits<int>::min() || *v > std::numeric_limits<int>::max())
    fail(key,
         range.what.empty() ? "an integer in [-2147483648, 2147483647]"
                            : expect_integer(range) + " and <= 2147483647",
         describe(*lookup(key)));
  return static_cast<int>(*v);
}

std::optional<std::int64_t> SectionReader::optional_int64(std::string_view key, const Range& range) {
  describe_key(key, "integer", expect_integer(range), false, range.ok);
  const toml::node* n = lookup(key);
  if (!n) return std::nullopt;
  auto i = n->as_integer();
  if (!i) fail(key, expect_integer(range), describe(*n));
  const std::int64_t v = i->get();
  if (!range.ok(static_cast<double>(v))) fail(key, expect_integer(range), describe(*n));
  return v;
}

std::string SectionReader::string(std::string_view key, std::optional<std::string> dflt, bool nonempty) {
  const std::string what = nonempty ? "a non-empty string" : "a string";
  describe_key(key, "string", what, !dflt);
  const toml::node* n = lookup(key);
  if (!n) {
    if (!dflt && g_schema) return "x";
    if (!dflt) missing(key, what);
    return *dflt;
  }
  auto s = n->as_string();
  if (!s || (nonempty && s->get().empty())) fail(key, what, describe(*n));
  return s->get();
}

bool SectionReader::boolean(std::string_view key, bool dflt) {
  describe_key(key, "boolean", "a boolean (true or false)", false);
  const toml::node* n = lookup(key);
  if (!n) return dflt;
  auto b = n->as_boolean();
  if (!b) fail(key, "a boolean (true or false)", describe(*n));
  return b->get();
}

std::optional<std::vector<double>> SectionReader::numbers(std::string_view key, bool required, std::size_t length,
                                                          const Range& range) {
  std::string what = length ? "an array of " + std::to_string(length) + " finite numbers"
                            : "a non-empty array of finite numbers";
  if (!range.what.empty()) what += " " + range.what;
  describe_key(key, "numbers", what, required, range.ok, {}, length);
  const toml::node* n = lookup(key);
  if (!n) {
    if (required && g_schema) return std::vector<double>(length ? length : 1, 1.0);
    if (required) missing(key, what);
    return std::nullopt;
  }
  auto a = n->as_array();
  if (!a) fail(key, what, describe(*n));
  if ((length && a->size() != length) || a->empty())
    fail(key, what, "an array of " + std::to_string(a->size()) + " element" + (a->size() == 1 ? "" : "s"));
  std::vector<double> out;
  for (std::size_t i = 0; i < a->size(); ++i) {
    const toml::node& e = *a->get(i);
    double v = 0.0;
    if (auto iv = e.as_integer()) {
      v = static_cast<double>(iv->get());
    } else if (auto fv = e.as_floating_point()) {
      v = fv->get();
    } else {
      fail(key, what, "element " + std::to_string(i + 1) + " " + describe(e));
    }
    if (!std::isfinite(v) || !range.ok(v)) fail(key, what, "element " + std::to_string(i + 1) + " " + describe(e));
    out.push_back(v);
  }
  return out;
}

std::string SectionReader::choice(std::string_view key, const std::string& dflt,
                                  const std::vector<std::string>& choices) {
  std::string what = "one of";
  for (std::size_t i = 0; i < choices.size(); ++i) what += (i ? ", \"" : " \"") + choices[i] + "\"";
  describe_key(key, "choice", what, false, {}, choices);
  const toml::node* n = lookup(key);
  if (!n) return dflt;
  auto s = n->as_string();
  if (!s) fail(key, what, describe(*n));
  for (const auto& c : choices)
    if (s->get() == c) return c;
  fail(key, what, describe(*n));
}

void SectionReader::finish() const {
  if (!table_) return;
  for (const auto& [k, v] : *table_) {
    if (std::find(asked_.begin(), asked_.end(), k.str()) != asked_.end()) continue;
    std::string known;
    for (const auto& a : asked_) known += (known.empty() ? "" : ", ") + a;
    fail(k.str(), "one of the keys of [" + section_ + "] (" + known + ")",
         "unknown key '" + one_line(std::string(k.str())) + "'");
  }
}

void SectionReader::describe_key(std::string_view key, const char* type, const std::string& expected, bool required,
                                 std::function<bool(double)> accepts, std::vector<std::string> choices,
                                 std::size_t length) const {
  if (!g_schema) return;
  for (const ConfigKey& k : *g_schema)
    if (k.section == section_ && k.key == key) return;  // number() then optional_number(): the first says more
  ConfigKey k;
  k.section = section_;
  k.array_section = label_.rfind("[[", 0) == 0;
  k.key = std::string(key);
  k.type = type;
  k.expected = expected;
  k.required = required;
  k.accepts = std::move(accepts);
  k.choices = std::move(choices);
  k.length = length;
  g_schema->push_back(std::move(k));
}

const toml::node* SectionReader::lookup(std::string_view key) {
  if (std::find(asked_.begin(), asked_.end(), key) == asked_.end()) asked_.emplace_back(key);
  return table_ ? table_->get(key) : nullptr;
}

void SectionReader::fail(std::string_view key, const std::string& expected, const std::string& got) const {
  if (origins_) {
    auto it = origins_->find({table_, std::string(key)});
    if (it != origins_->end()) throw InputError(it->second + ": expected " + expected + ", got " + got);
  }
  throw InputError(source_ + ": " + label_ + " " + one_line(std::string(key)) + ": expected " + expected +
                   ", got " + got);
}

void SectionReader::missing(std::string_view key, const std::string& expected) const {
  fail(key, expected, "nothing (this key is required)");
}

}  // namespace capsflow::config_detail
