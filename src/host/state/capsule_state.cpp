// The implementation of capsule_state.hpp: the capsule state in structure-of-arrays form and its reference data.
#include "host/state/capsule_state.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <string>

#include "host/base/backend_select.hpp"
#include "host/base/errors.hpp"
#include "kernels/capsule_geometry.hpp"
#include "kernels/constants.hpp"

namespace capsflow {

namespace {

void validate_membrane(const MembraneParameters& p) {
  if (!(p.inflation >= 0.0) || !std::isfinite(p.inflation))
    throw InputError("membrane inflation beta must be >= 0 and finite, got " + std::to_string(p.inflation));
  if (p.law != MembraneLaw::NeoHookean && p.law != MembraneLaw::Skalak && p.law != MembraneLaw::SurfaceTension)
    throw InputError("unknown membrane law " + std::to_string(static_cast<int>(p.law)));
  if (p.law == MembraneLaw::Skalak && !(p.skalak_C > 0.0 && std::isfinite(p.skalak_C)))
    throw InputError("Skalak parameter C must be > 0 and finite, got " + std::to_string(p.skalak_C));
}

}  // namespace

CapsuleState::CapsuleState(int mesh_level, MembraneParameters params) : mesh_(&icosphere(mesh_level)), params_(params) {
  validate_membrane(params_);
}

int CapsuleState::add_species(double Ca, double bending_modulus) {
  SpeciesProperties p;
  p.Ca = Ca;
  p.bending_modulus = bending_modulus;
  p.membrane = params_;
  return add_species(p);
}

int CapsuleState::add_species(const SpeciesProperties& p) {
  if (!(p.Ca > 0.0) || !std::isfinite(p.Ca))
    throw InputError("capillary number must be positive and finite, got " + std::to_string(p.Ca));
  if (!(p.bending_modulus >= 0.0) || !std::isfinite(p.bending_modulus))
    throw InputError("bending modulus must be >= 0 and finite, got " + std::to_string(p.bending_modulus));
  validate_membrane(p.membrane);
  validate_shape(p.shape, 1.0);
  const TriMesh& m = *mesh_;
  if (p.shape.kind == ShapeKind::Sphere) {  // the icosphere's own nodes: today's bits
    unit_x_.push_back(m.x);
    unit_y_.push_back(m.y);
    unit_z_.push_back(m.z);
  } else {
    std::vector<double> ux = m.x, uy = m.y, uz = m.z;
    map_to_shape(p.shape, 1.0, ux, uy, uz);
    unit_x_.push_back(std::move(ux));
    unit_y_.push_back(std::move(uy));
    unit_z_.push_back(std::move(uz));
  }
  species_props_.push_back(p);
  return static_cast<int>(species_props_.size()) - 1;
}

int CapsuleState::add_capsule(const std::array<double, 3>& center, double radius, int species,
                              const Rotation& R) {
  if (!(radius > 0.0) || !std::isfinite(radius))
    throw InputError("capsule radius must be positive and finite, got " + std::to_string(radius));
  if (species < 0 || species >= num_species())
    throw InputError("unknown capsule species " + std::to_string(species));
  for (double v : center)
    if (!std::isfinite(v)) throw InputError("capsule centre must be finite");
  // R R^T = 1 and det R = +1: a reflection would turn the triangles inside out.
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const double d = R[3 * i] * R[3 * j] + R[3 * i + 1] * R[3 * j + 1] + R[3 * i + 2] * R[3 * j + 2];
      if (!(std::abs(d - (i == j ? 1.0 : 0.0)) <= 1e-12))
        throw InputError("capsule orientation is not a rotation (rows not orthonormal)");
    }
  const double det = R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6]) +
                     R[2] * (R[3] * R[7] - R[4] * R[6]);
  if (!(det > 0.0)) throw InputError("capsule orientation is a reflection, not a rotation");
  const SpeciesProperties& sp = species_props_[species];
  const std::vector<double>&ux = unit_x_[species], &uy = unit_y_[species], &uz = unit_z_[species];
  const TriMesh& m = *mesh_;
  const int nv = m.num_nodes(), nt = m.num_triangles();
  const double r0 = radius / (1.0 + sp.membrane.inflation);
  const bool turned = R != kIdentityRotation;
  std::vector<double> X(nv), Y(nv), Z(nv);
  for (int i = 0; i < nv; ++i) {
    double bx = ux[i], by = uy[i], bz = uz[i];  // body frame, unit radius
    if (turned) {
      const double px = bx, py = by, pz = bz;
      bx = R[0] * px + R[1] * py + R[2] * pz;
      by = R[3] * px + R[4] * py + R[5] * pz;
      bz = R[6] * px + R[7] * py + R[8] * pz;
    }
    x.push_back(center[0] + radius * bx);
    y.push_back(center[1] + radius * by);
    z.push_back(center[2] + radius * bz);
    X[i] = center[0] + r0 * bx;
    Y[i] = center[1] + r0 * by;
    Z[i] = center[2] + r0 * bz;
  }
  const std::size_t e0 = area0_.size();
  for (auto* v : {&area0_, &g1x_, &g1y_, &g2x_, &g2y_}) v->resize(e0 + nt);
  membrane_reference(1, nv, nt, m.tri.data(), X.data(), Y.data(), Z.data(), area0_.data() + e0, g1x_.data() + e0,
                     g1y_.data() + e0, g2x_.data() + e0, g2y_.data() + e0);
  species_.push_back(species);
  radius_.push_back(radius);
  Gs_.push_back(radius / sp.Ca);  // Gs = mu gammadot a / Ca with mu = gammadot = 1
  law_.push_back(sp.membrane.law);
  Cs_.push_back(sp.membrane.skalak_C);
  kappa_.push_back(sp.bending_modulus * Gs_.back() * radius * radius);
  has_bending_ = has_bending_ || kappa_.back() > 0.0;
  return num_capsules() - 1;
}

MeshTopology CapsuleState::topology() const {
  MeshTopology t;
  t.nv = mesh_->num_nodes();
  t.ntri = mesh_->num_triangles();
  t.tri = mesh_->tri.data();
  t.inc_offsets = mesh_->inc_offsets.data();
  t.inc_tri = mesh_->inc_tri.data();
  t.inc_corner = mesh_->inc_corner.data();
  return t;
}

BendingTopology bending_topology(const TriMesh& m) {
  return {m.num_nodes(),        m.num_triangles(),    m.num_edges(),     m.tri.data(),
          m.edge_quad.data(),   m.inc_offsets.data(), m.inc_tri.data(),  m.inc_corner.data(),
          m.einc_offsets.data(), m.einc_edge.data(),  m.einc_slot.data()};
}

BendingTopology CapsuleState::bending_topology() const { return capsflow::bending_topology(*mesh_); }

MembraneReference CapsuleState::reference() const {
  return {area0_.data(), g1x_.data(), g1y_.data(), g2x_.data(), g2y_.data()};
}

void CapsuleState::compute_membrane_forces(Backend backend) {
  compute_in_plane_forces(backend);
  // Without bending the kernel is not called at all, so such runs keep their bits.
  if (has_bending_) add_bending_forces(backend, Fx.data(), Fy.data(), Fz.data(), node_area.data(), fx.data(),
                                       fy.data(), fz.data());
}

void CapsuleState::compute_in_plane_forces(Backend backend) {
  require_backend(backend);
  const std::size_t nn = x.size();
  for (auto* v : {&Fx, &Fy, &Fz, &node_area, &fx, &fy, &fz}) v->resize(nn);
  work_.resize(10 * area0_.size());
  membrane_forces(backend, law_.data(), Cs_.data(), num_capsules(), topology(), reference(), Gs_.data(),
                  x.data(), y.data(), z.data(), MembraneWork{work_.data()}, Fx.data(), Fy.data(), Fz.data(),
                  node_area.data(), fx.data(), fy.data(), fz.data());
}

void CapsuleState::add_bending_forces(Backend backend, double* Fx_, double* Fy_, double* Fz_, const double* area,
                                      double* fx_, double* fy_, double* fz_) const {
  const std::size_t nc = static_cast<std::size_t>(num_capsules());
  const TriMesh& m = *mesh_;
  bend_edge_.resize(13 * nc * m.num_edges());
  bend_tri_.resize(12 * nc * m.num_triangles());
  bend_node_.resize(2 * nc * m.num_nodes());
  bending_forces(backend, num_capsules(), bending_topology(), kappa_.data(), x.data(), y.data(), z.data(),
                 BendingWork{bend_edge_.data(), bend_tri_.data(), bend_node_.data()}, Fx_, Fy_, Fz_, area, fx_, fy_,
                 fz_);
}

MembraneNodeFields membrane_node_fields(const CapsuleState& s) {
  const std::size_t nn = s.x.size();
  const int ncap = s.num_capsules(), nv = s.nodes_per_capsule(), ntri = s.triangles_per_capsule();
  const MembraneReference ref = s.reference();
  const std::vector<double>& Gs = s.shear_modulus();
  const std::vector<MembraneLaw>& law = s.membrane_law();
  const std::vector<double>& Cs = s.skalak_c();
  MembraneNodeFields out;
  std::vector<double> Fx(nn), Fy(nn), Fz(nn), area(nn), fx(nn), fy(nn), fz(nn);
  std::vector<double> work(10 * static_cast<std::size_t>(ncap) * ntri);
  membrane_forces(Backend::Serial, law.data(), Cs.data(), ncap, s.topology(), ref, Gs.data(), s.x.data(), s.y.data(),
                  s.z.data(), MembraneWork{work.data()}, Fx.data(), Fy.data(), Fz.data(), area.data(), fx.data(),
                  fy.data(), fz.data());
  if (s.has_bending())
    s.add_bending_forces(Backend::Serial, Fx.data(), Fy.data(), Fz.data(), area.data(), fx.data(), fy.data(),
                         fz.data());
  out.traction_jump.resize(3 * nn);
  for (std::size_t i = 0; i < nn; ++i) {
    out.traction_jump[3 * i] = -fx[i];
    out.traction_jump[3 * i + 1] = -fy[i];
    out.traction_jump[3 * i + 2] = -fz[i];
  }
  out.tension_max.assign(nn, 0.0);
  out.tension_min.assign(nn, 0.0);
  out.energy_density.assign(nn, 0.0);
  std::vector<double> weight(nn, 0.0);
  const std::vector<int>& tri = s.mesh().tri;
  for (int k = 0; k < ncap; ++k)
    for (int t = 0; t < ntri; ++t) {
      const std::size_t e = static_cast<std::size_t>(k) * ntri + t;
      std::size_t n[3];
      for (int c = 0; c < 3; ++c) n[c] = static_cast<std::size_t>(k) * nv + tri[3 * t + c];
      double t1, t2, W;
      membrane_element_tensions(law[k], Gs[k], Cs[k], s.x[n[0]], s.y[n[0]], s.z[n[0]], s.x[n[1]], s.y[n[1]],
                                s.z[n[1]], s.x[n[2]], s.y[n[2]], s.z[n[2]], ref.g1x[e], ref.g1y[e], ref.g2x[e],
                                ref.g2y[e], t1, t2, W);
      const double a = work[10 * e + 9];  // the element's current area, as membrane_forces left it
      for (std::size_t i : n) {
        out.tension_max[i] += a * t1;
        out.tension_min[i] += a * t2;
        out.energy_density[i] += a * W;
        weight[i] += a;
      }
    }
  for (std::size_t i = 0; i < nn; ++i) {
    out.tension_max[i] /= weight[i];
    out.tension_min[i] /= weight[i];
    out.energy_density[i] /= weight[i];
  }
  return out;
}

std::vector<double> CapsuleState::membrane_energy() const {
  std::vector<double> e(num_capsules());
  capsflow::membrane_energy(law_.data(), Cs_.data(), num_capsules(), topology(), reference(), Gs_.data(),
                            x.data(), y.data(), z.data(), e.data());
  if (has_bending_) {
    std::vector<double> eb(e.size());
    bending_energy(num_capsules(), bending_topology(), kappa_.data(), x.data(), y.data(), z.data(), eb.data());
    for (std::size_t k = 0; k < e.size(); ++k) e[k] += eb[k];
  }
  return e;
}

TaylorDeformation taylor_deformation(const double* m6, double volume) {
  Eigen::Matrix3d M;
  M << m6[0], m6[3], m6[4], m6[3], m6[1], m6[5], m6[4], m6[5], m6[2];
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(M);
  const Eigen::Vector3d mu = es.eigenvalues();  // ascending
  const Eigen::Matrix3d ev = es.eigenvectors();
  TaylorDeformation d;
  std::array<double, 3> ax{};
  for (int i = 0; i < 3; ++i) ax[i] = std::sqrt(std::max(0.0, 5.0 * mu[i] / volume));
  d.semi_axes = {ax[2], ax[1], ax[0]};
  // The vorticity (z) axis is the principal axis most aligned with z; the other two span the shear plane.
  int iz = 0;
  for (int i = 1; i < 3; ++i)
    if (std::abs(ev(2, i)) > std::abs(ev(2, iz))) iz = i;
  int ia = -1, ib = -1;
  for (int i = 0; i < 3; ++i) {
    if (i == iz) continue;
    if (ia < 0) ia = i;
    else ib = i;
  }
  const int il = ax[ia] >= ax[ib] ? ia : ib, is = il == ia ? ib : ia;
  d.L = ax[il];
  d.B = ax[is];
  d.D = (d.L - d.B) / (d.L + d.B);
  double ang = std::atan2(ev(1, il), ev(0, il));  // an axis: fold the direction into (-pi/2, pi/2]
  if (ang > kPi / 2) ang -= kPi;
  if (ang <= -kPi / 2) ang += kPi;
  d.inclination = ang;
  return d;
}

CapsuleGeometry compute_geometry(const CapsuleState& s, Backend backend) {
  require_backend(backend);
  const int nc = s.num_capsules(), nv = s.nodes_per_capsule(), nt = s.triangles_per_capsule();
  CapsuleGeometry g;
  g.volume.resize(nc);
  g.area.resize(nc);
  g.centroid.resize(3 * nc);
  g.moments.resize(6 * nc);
  g.min_edge.resize(nc);
  capsule_shape(backend, nc, nv, nt, s.mesh().tri.data(), s.x.data(), s.y.data(), s.z.data(), g.volume.data(),
                g.area.data(), g.centroid.data(), g.moments.data());
  min_edge_length(backend, nc, nv, s.mesh().num_edges(), s.mesh().edges.data(), s.x.data(), s.y.data(), s.z.data(),
                  g.min_edge.data());
  g.deformation.resize(nc);
  for (int k = 0; k < nc; ++k) g.deformation[k] = taylor_deformation(&g.moments[6 * k], g.volume[k]);
  g.global_min_edge = nc ? *std::min_element(g.min_edge.begin(), g.min_edge.end()) : 0.0;
  return g;
}

void compute_mean_velocity(const CapsuleState& s, Backend backend, const std::vector<double>& ux,
                           const std::vector<double>& uy, const std::vector<double>& uz, std::vector<double>& U,
                           std::vector<double>& omega) {
  require_backend(backend);
  if (ux.size() != s.x.size() || uy.size() != s.x.size() || uz.size() != s.x.size())
    throw InputError("compute_mean_velocity: velocity arrays must have one entry per node");
  const int nc = s.num_capsules();
  U.resize(3 * nc);
  omega.resize(3 * nc);
  capsule_mean_velocity(backend, nc, s.nodes_per_capsule(), s.triangles_per_capsule(), s.mesh().tri.data(),
                        s.x.data(), s.y.data(), s.z.data(), ux.data(), uy.data(), uz.data(), U.data(), omega.data());
}

void compute_node_normals(const CapsuleState& s, Backend backend, std::vector<double>& nx, std::vector<double>& ny,
                          std::vector<double>& nz) {
  require_backend(backend);
  const std::size_t nn = s.x.size();
  nx.resize(nn);
  ny.resize(nn);
  nz.resize(nn);
  node_normals(backend, s.num_capsules(), s.nodes_per_capsule(), s.mesh().tri.data(), s.mesh().inc_offsets.data(),
               s.mesh().inc_tri.data(), s.x.data(), s.y.data(), s.z.data(), nx.data(), ny.data(), nz.data());
}

}  // namespace capsflow
