// The implementation of digest.hpp.
#include "host/base/digest.hpp"

#include <cstdio>
#include <cstring>

namespace capsflow {

void Digest64::add(std::uint64_t word) {
  // One odd-constant multiply spreads the low bits upward; the shift folds the high bits back before the next word.
  h_ = (h_ ^ word) * 0x9E3779B97F4A7C15ULL;
  h_ ^= h_ >> 32;
}

void Digest64::add(double v) {
  std::uint64_t w;
  std::memcpy(&w, &v, sizeof w);
  add(w);
}

void Digest64::add(std::string_view text) {
  add(static_cast<std::uint64_t>(text.size()));
  for (std::size_t i = 0; i < text.size(); i += 8) {
    std::uint64_t w = 0;
    for (std::size_t b = 0; b < 8 && i + b < text.size(); ++b)
      w |= static_cast<std::uint64_t>(static_cast<unsigned char>(text[i + b])) << (8 * b);
    add(w);
  }
}

void Digest64::add(const std::vector<double>& v) {
  add(static_cast<std::uint64_t>(v.size()));
  for (double x : v) add(x);
}

void Digest64::add(const std::vector<std::int64_t>& v) {
  add(static_cast<std::uint64_t>(v.size()));
  for (std::int64_t x : v) add(x);
}

std::string Digest64::hex() const {
  // A final avalanche, so that the last words reach every bit of the printed value.
  std::uint64_t h = h_;
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ULL;
  h ^= h >> 32;
  char s[24];
  std::snprintf(s, sizeof s, "h64:%016llx", static_cast<unsigned long long>(h));
  return s;
}

std::string text_digest(std::string_view text) {
  Digest64 d;
  d.add(text);
  return d.hex();
}

}  // namespace capsflow
