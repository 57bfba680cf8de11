#pragma once
// Small helpers shared by the tests: reproducible random data and relative errors.
#include <cstdint>
#include <random>
#include <vector>

namespace capsflow::test {

// Uniform values in [lo, hi), reproducible from the seed.
std::vector<double> uniform_values(std::size_t n, double lo, double hi, std::uint64_t seed);

// max_i |a_i - b_i| / max_i |b_i| (b the reference); 0 when both are zero.
double max_rel_error(const std::vector<double>& a, const std::vector<double>& b);

}  // namespace capsflow::test
