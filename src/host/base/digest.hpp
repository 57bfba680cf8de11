#pragma once
// Digest64: a 64-bit digest of values fed in order, to tell whether a stored file's contents are the ones its writer
// wrote (a checkpoint's /state and configuration). It guards against edits and damage, not against an adversary: a
// multiply-xorshift mix over 64-bit words, simple enough to recompute in a few lines of Python
// (tools/set_checkpoint_cfl.py does, for the configuration it rewrites). Its definition is part of the file format
// (docs/output_format.md): changing it turns every stored digest into a mismatch.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace capsflow {

class Digest64 {
 public:
  // Each value is one word: an integer as its two's-complement bits, a double as its IEEE-754 bits.
  void add(std::uint64_t word);
  void add(std::int64_t v) { add(static_cast<std::uint64_t>(v)); }
  void add(double v);
  // A text: its length in bytes, then its bytes in little-endian words of eight (the last one zero-padded).
  void add(std::string_view text);
  // An array: its length, then its values.
  void add(const std::vector<double>& v);
  void add(const std::vector<std::int64_t>& v);
  // "h64:" and 16 lowercase hex digits.
  std::string hex() const;

 private:
  std::uint64_t h_ = 0x243F6A8885A308D3ULL;  // the digits of pi: any fixed non-zero start
};

// The digest of a text alone (Digest64 fed the text once).
std::string text_digest(std::string_view text);

}  // namespace capsflow
