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

  // Whether a stored capsule overlaps one at p: their centres closer than the sum of the two bounding radii (r for
  // p, radius[id] for the stored ones) plus gap (nearest periodic image), and `overlap(id, p - q)` confirms it (the
  // shapes' own test; spheres: always). The cells must be at least that sum wide.
  template <class Overlap>
  bool conflicts(const std::array<double, 3>& p, double r, double gap, const std::vector<CapsulePlacement>& placed,
                 const std::vector<double>& radius, const Overlap& overlap) const {
    const int ix = cx(p[0]), iy = cy(p[1]), iz = cz(p[2]);
    for (int ox : offsets(nx_))
      for (int oy = -1; oy <= 1; ++oy)
        for (int oz : offsets(nz_)) {
          const int jy = iy + oy;
          if (jy < 0 || jy >= ny_) continue;
          const int jx = nx_ < 3 ? ox : (ix + ox + nx_) % nx_;
          const int jz = nz_ < 3 ? oz : (iz + oz + nz_) % nz_;
          for (int id : cells_[index(jx, jy, jz)]) {
            const auto& q = placed[static_cast<std::size_t>(id)].center;
            const double dmin = r + radius[static_cast<std::size_t>(id)] + gap;  // 2a + gap for equal spheres
            const double d2min = dmin * dmin;
            const double dx = min_image(p[0] - q[0], Lx_), dy = p[1] - q[1], dz = min_image(p[2] - q[2], Lz_);
            if (dx * dx + dy * dy + dz * dz < d2min && overlap(id, std::array<double, 3>{dx, dy, dz})) return true;
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

// A species' shape as placement sees it: its equal-volume radius a, bounding radius r, and the nodes of a level-3
// mesh of the shape at unit radius (body frame) for the overlap and wall tests of turned shapes.
struct PlacementShape {
  ShapeSpec shape;
  double a = 1.0, r = 1.0;
  std::vector<double> x, y, z;
};

// Whether the body-frame point q (units of a) is inside the unit-radius shape.
bool inside_unit_shape(const ShapeSpec& s, double qx, double qy, double qz) {
  switch (s.kind) {
    case ShapeKind::Sphere:
      return qx * qx + qy * qy + qz * qz < 1.0;
    case ShapeKind::Spheroid: {
      const SpheroidAxes ax = spheroid_axes(s.aspect, 1.0);
      return (qx * qx + qy * qy) / (ax.b * ax.b) + qz * qz / (ax.c * ax.c) < 1.0;
    }
    case ShapeKind::Biconcave: {
      const double R0 = evans_fung_disc_radius(1.0), rho = std::hypot(qx, qy) / R0;
      return rho < 1.0 && std::abs(qz) < evans_fung_half_thickness(rho, R0);
    }
  }
  return false;
}

// Whether capsule A (shape sa, turn Ra) at offset d from capsule B (shape sb, turn Rb) overlaps it, each dilated by
// gap: some node of either mesh lies inside the other shape scaled by (a + gap) / a. A node test, so thin regions
// may come a little closer than gap; the run's contact control restores min_gap in its first step.
bool shapes_overlap(const PlacementShape& sa, const Rotation& Ra, const PlacementShape& sb, const Rotation& Rb,
                    const std::array<double, 3>& d, double gap) {
  auto any_inside = [gap](const PlacementShape& from, const Rotation& Rf, const PlacementShape& to,
                          const Rotation& Rt, double ox, double oy, double oz) {
    const double scale = 1.0 / (to.a + gap);
    for (std::size_t i = 0; i < from.x.size(); ++i) {
      const double bx = from.a * from.x[i], by = from.a * from.y[i], bz = from.a * from.z[i];
      const double px = ox + Rf[0] * bx + Rf[1] * by + Rf[2] * bz;  // lab offset from `to`'s centre
      const double py = oy + Rf[3] * bx + Rf[4] * by + Rf[5] * bz;
      const double pz = oz + Rf[6] * bx + Rf[7] * by + Rf[8] * bz;
      const double qx = (Rt[0] * px + Rt[3] * py + Rt[6] * pz) * scale;  // R^T p: into `to`'s body frame
      const double qy = (Rt[1] * px + Rt[4] * py + Rt[7] * pz) * scale;
      const double qz = (Rt[2] * px + Rt[5] * py + Rt[8] * pz) * scale;
      if (inside_unit_shape(to.shape, qx, qy, qz)) return true;
    }
    return false;
  };
  return any_inside(sa, Ra, sb, Rb, d[0], d[1], d[2]) || any_inside(sb, Rb, sa, Ra, -d[0], -d[1], -d[2]);
}

// Half-extent in y of a turned shape: the largest |y| of its (lab-frame) mesh nodes.
double y_extent(const PlacementShape& s, const Rotation& R) {
  double e = 0.0;
  for (std::size_t i = 0; i < s.x.size(); ++i) e = std::max(e, std::abs(R[3] * s.x[i] + R[4] * s.y[i] + R[5] * s.z[i]));
  return s.a * e;
}

}  // namespace

long suspension_count(const Config& c) {
  const SuspensionSpec& s = *c.suspension;
  if (s.count) return *s.count;
  const double phi = *s.volume_fraction;
  const double n = std::round(phi * c.domain.H * c.domain.Lx * c.domain.Lz / mean_capsule_volume(c));
  if (n < 1.0)
    throw InputError(c.origin("[suspension] volume_fraction") + ": volume fraction " + fixed2(phi) +
                     " gives no capsule in this box (round(phi H Lx Lz / mean capsule volume) = 0); raise it, enlarge "
                     "the box, or give [suspension] count");
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
      out.push_back({p, c.species_index(e.species), e.pinned,
                     e.orientation ? rotation_to_axis(*e.orientation) : kIdentityRotation});
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

  // Bounding spheres: r per species (the radius for spheres); the cells hold the largest pair distance. Spheres use
  // them alone (today's placement, bit for bit); turned shapes are tested against each other by their meshes.
  const double gap = c.time.min_gap;
  const double Lx = c.domain.Lx, Lz = c.domain.Lz, H = c.domain.H;
  std::vector<double> r_species(c.species.size()), v_species(c.species.size());
  std::vector<PlacementShape> shapes(c.species.size());
  for (std::size_t k = 0; k < c.species.size(); ++k) {
    r_species[k] = c.species_bounding_radius(k);
    const double a = c.species_radius(k);
    v_species[k] = 4.0 / 3.0 * kPi * a * a * a;
    PlacementShape& ps = shapes[k];
    ps.shape = c.species[k].shape;
    ps.a = a;
    ps.r = r_species[k];
    const TriMesh m = shape_mesh(ps.shape, 1.0, 3);  // spheres too: a sphere against a turned shape
    ps.x = m.x;
    ps.y = m.y;
    ps.z = m.z;
  }
  auto is_sphere = [&](int label) { return shapes[static_cast<std::size_t>(label)].shape.kind == ShapeKind::Sphere; };
  const double rmax = *std::max_element(r_species.begin(), r_species.end());
  CellGrid grid(Lx, H, Lz, 2.0 * rmax + gap);
  // Orientations come from their own stream, so that adding shapes changed no sphere's position.
  std::mt19937_64 orientation_rng(s.seed ^ 0x6a09e667f3bcc909ULL);
  std::vector<double> r_placed;
  out.reserve(labels.size());
  r_placed.reserve(labels.size());
  long attempts = 0;
  double v_placed = 0.0, v_total = 0.0;
  for (int label : labels) v_total += v_species[static_cast<std::size_t>(label)];
  for (int label : labels) {
    const double r = r_species[static_cast<std::size_t>(label)];
    const PlacementShape& shape = shapes[static_cast<std::size_t>(label)];
    bool placed = false;
    for (long t = 0; t < kMaxTriesPerCapsule && !placed; ++t) {
      ++attempts;
      // A turned shape draws its orientation first: its extent in y sets where its centre may go.
      Rotation turn = kIdentityRotation;
      double ext = r;
      if (!is_sphere(label)) {
        const double u1 = uniform01(orientation_rng), u2 = uniform01(orientation_rng);
        turn = uniform_rotation(u1, u2, uniform01(orientation_rng));
        ext = y_extent(shape, turn);
      }
      const double ylo = ext + gap, yhi = H - ext - gap;
      const std::array<double, 3> p = {Lx * uniform01(rng), ylo + (yhi - ylo) * uniform01(rng), Lz * uniform01(rng)};
      auto overlap = [&](int id, const std::array<double, 3>& d) {
        const CapsulePlacement& q = out[static_cast<std::size_t>(id)];
        if (is_sphere(label) && is_sphere(q.species)) return true;  // bounding spheres are the spheres
        return shapes_overlap(shape, turn, shapes[static_cast<std::size_t>(q.species)], q.orientation, d, gap);
      };
      if (grid.conflicts(p, r, gap, out, r_placed, overlap)) continue;
      grid.insert(p, static_cast<int>(out.size()));
      out.push_back({p, label, false, turn});
      r_placed.push_back(r);
      v_placed += v_species[static_cast<std::size_t>(label)];
      placed = true;
    }
    if (!placed) {
      const double vbox = H * Lx * Lz;
      const double want = v_total / vbox;
      const double got = v_placed / vbox;
      // Name the key the user gave: count, or volume_fraction (issue 37, finding 7).
      const std::string key = s.count ? "count" : "volume_fraction";
      const std::string what = s.count ? "count " + std::to_string(total) + " (volume fraction " + fixed2(want) + ")"
                                       : "volume fraction " + fixed2(want);
      throw InputError(c.origin("[suspension] " + key) + ": " + what +
                       " could not be placed: random sequential placement stopped at " + fixed2(got) + " after " +
                       std::to_string(attempts) + " attempts (" + std::to_string(out.size()) + " of " +
                       std::to_string(total) + (total == 1 ? " capsule" : " capsules") + "); lower [suspension] " +
                       key + " or enlarge the box");
    }
  }
  return out;
}

}  // namespace capsflow
