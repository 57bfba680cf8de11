// Initial capsule placement (initial_conditions.hpp).
#include "host/physics/initial_conditions.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numeric>
#include <random>
#include <string>

#include "host/base/errors.hpp"
#include "kernels/ggem_kernels.hpp"

namespace capsflow {
namespace {

// Uniform in [0, 1) from the top 53 bits: the same sequence with every standard library (unlike
// std::uniform_real_distribution, whose algorithm is unspecified).
double uniform01(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

// Uniform integer in [0, n) (n >= 1), by rejection: portable, like uniform01.
std::uint64_t uniform_below(std::mt19937_64& rng, std::uint64_t n) {
  const std::uint64_t limit = std::numeric_limits<std::uint64_t>::max() - std::numeric_limits<std::uint64_t>::max() % n;
  std::uint64_t v = 0;
  do {
    v = rng();
  } while (v >= limit);
  return v % n;
}

std::string fixed2(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", v);
  return buf;
}

// Uniform grid of cells at least `dmin` wide over the box, periodic in x and z.
class CellGrid {
 public:
  CellGrid(double Lx, double H, double Lz, double dmin)
      : Lx_(Lx),
        H_(H),
        Lz_(Lz),
        nx_(std::max(1, static_cast<int>(Lx / dmin))),
        ny_(std::max(1, static_cast<int>(H / dmin))),
        nz_(std::max(1, static_cast<int>(Lz / dmin))),
        cells_(static_cast<std::size_t>(nx_) * ny_ * nz_) {}

  void insert(const std::array<double, 3>& p, int id) { cells_[index(cx(p[0]), cy(p[1]), cz(p[2]))].push_back(id); }

  // Whether any stored point is closer than dmin to p (nearest periodic image).
  bool conflicts(const std::array<double, 3>& p, double dmin, const std::vector<CapsulePlacement>& placed) const {
    const int ix = cx(p[0]), iy = cy(p[1]), iz = cz(p[2]);
    const double d2min = dmin * dmin;
    for (int ox : offsets(nx_))
      for (int oy = -1; oy <= 1; ++oy)
        for (int oz : offsets(nz_)) {
          const int jy = iy + oy;
          if (jy < 0 || jy >= ny_) continue;
          const int jx = nx_ < 3 ? ox : (ix + ox + nx_) % nx_;
          const int jz = nz_ < 3 ? oz : (iz + oz + nz_) % nz_;
          for (int id : cells_[index(jx, jy, jz)]) {
            const auto& q = placed[static_cast<std::size_t>(id)].center;
            const double dx = min_image(p[0] - q[0], Lx_), dy = p[1] - q[1], dz = min_image(p[2] - q[2], Lz_);
            if (dx * dx + dy * dy + dz * dz < d2min) return true;
          }
        }
    return false;
  }

 private:
  // Neighbour offsets, or every cell when the direction has fewer than 3 (no cell visited twice).
  static std::vector<int> offsets(int n) {
    if (n >= 3) return {-1, 0, 1};
    std::vector<int> all(static_cast<std::size_t>(n));
    std::iota(all.begin(), all.end(), 0);
    return all;
  }
  static int clampi(int i, int n) { return std::min(std::max(i, 0), n - 1); }
  int cx(double x) const { return clampi(static_cast<int>(x / Lx_ * nx_), nx_); }
  int cy(double y) const { return clampi(static_cast<int>(y / H_ * ny_), ny_); }
  int cz(double z) const { return clampi(static_cast<int>(z / Lz_ * nz_), nz_); }
  std::size_t index(int ix, int iy, int iz) const { return (static_cast<std::size_t>(ix) * ny_ + iy) * nz_ + iz; }

  double Lx_, H_, Lz_;
  int nx_, ny_, nz_;
  std::vector<std::vector<int>> cells_;
};

}  // namespace

long suspension_count(const Config& c) {
  const SuspensionSpec& s = *c.suspension;
  if (s.count) return *s.count;
  const double a = c.capsules.radius;
  const double phi = *s.volume_fraction;
  const double n = std::round(phi * c.domain.H * c.domain.Lx * c.domain.Lz / (4.0 / 3.0 * kPi * a * a * a));
  if (n < 1.0)
    throw InputError(c.source + ": [suspension] volume_fraction: volume fraction " + fixed2(phi) +
                     " gives no capsule in this box (round(phi H Lx Lz / (4/3 pi a^3)) = 0); raise it, enlarge the "
                     "box, or give [suspension] count");
  return static_cast<long>(n);
}

std::vector<long> species_counts(long total, const std::vector<double>& fractions) {
  const std::size_t n = fractions.size();
  std::vector<long> counts(n, 0);
  std::vector<double> rem(n, 0.0);
  long assigned = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double exact = static_cast<double>(total) * fractions[i];
    counts[i] = static_cast<long>(std::floor(exact));
    rem[i] = exact - static_cast<double>(counts[i]);
    assigned += counts[i];
  }
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t i, std::size_t j) { return rem[i] > rem[j]; });
  for (std::size_t k = 0; assigned < total && n > 0; k = (k + 1) % n, ++assigned) ++counts[order[k]];
  while (assigned > total) {  // only from rounding of fractions that sum slightly above 1
    auto it = std::max_element(counts.begin(), counts.end());
    --*it;
    --assigned;
  }
  return counts;
}

std::vector<CapsulePlacement> place_capsules(const Config& c) {
  validate_run_config(c);
  std::vector<CapsulePlacement> out;
  if (!c.capsule_list.empty()) {
    // x and z may take any value (periodic): the capsule starts at the image in [0, L), exactly (fmod), so that a
    // centre at 1e300 does not collapse its nodes onto one double.
    auto wrap = [](double v, double L) {
      const double w = std::fmod(v, L);
      return w < 0.0 ? (w + L < L ? w + L : 0.0) : w;
    };
    for (const auto& e : c.capsule_list) {
      std::array<double, 3> p = e.center;
      p[0] = wrap(p[0], c.domain.Lx);
      p[2] = wrap(p[2], c.domain.Lz);
      out.push_back({p, c.species_index(e.species), e.pinned});
    }
    return out;
  }

  const SuspensionSpec& s = *c.suspension;
  const long total = suspension_count(c);
  const std::vector<long> per_species = species_counts(total, s.fractions);

  std::mt19937_64 rng(s.seed);
  std::vector<int> labels;
  labels.reserve(static_cast<std::size_t>(total));
  for (std::size_t k = 0; k < per_species.size(); ++k)
    labels.insert(labels.end(), static_cast<std::size_t>(per_species[k]), static_cast<int>(k));
  for (std::size_t i = labels.size(); i > 1; --i)  // Fisher-Yates with the portable uniform_below
    std::swap(labels[i - 1], labels[static_cast<std::size_t>(uniform_below(rng, i))]);

  const double a = c.capsules.radius, gap = c.time.min_gap;
  const double Lx = c.domain.Lx, Lz = c.domain.Lz, H = c.domain.H;
  const double ylo = a + gap, yhi = H - a - gap, dmin = 2.0 * a + gap;
  CellGrid grid(Lx, H, Lz, dmin);
  out.reserve(labels.size());
  long attempts = 0;
  for (int label : labels) {
    bool placed = false;
    for (long t = 0; t < kMaxTriesPerCapsule && !placed; ++t) {
      ++attempts;
      const std::array<double, 3> p = {Lx * uniform01(rng), ylo + (yhi - ylo) * uniform01(rng), Lz * uniform01(rng)};
      if (grid.conflicts(p, dmin, out)) continue;
      grid.insert(p, static_cast<int>(out.size()));
      out.push_back({p, label, false});
      placed = true;
    }
    if (!placed) {
      const double vcap = 4.0 / 3.0 * kPi * a * a * a, vbox = H * Lx * Lz;
      const double want = static_cast<double>(total) * vcap / vbox;
      const double got = static_cast<double>(out.size()) * vcap / vbox;
      throw InputError(c.source + ": [suspension] volume_fraction: volume fraction " + fixed2(want) +
                       " could not be placed: random sequential placement stopped at " + fixed2(got) + " after " +
                       std::to_string(attempts) + " attempts (" + std::to_string(out.size()) + " of " +
                       std::to_string(total) + (total == 1 ? " capsule" : " capsules") + "); lower [suspension] volume_fraction or enlarge the box");
    }
  }
  return out;
}

}  // namespace capsflow
