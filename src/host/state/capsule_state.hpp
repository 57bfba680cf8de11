#pragma once
// Capsule state in structure-of-arrays form, its membrane reference data, and per-capsule geometry
// (docs/method.md §2.2-2.3, §2.4; docs/method.md).
//
// All capsules share one icosphere level (one connectivity). Nodes of all capsules live in contiguous x, y, z
// arrays: capsule k owns nodes [k nv, (k+1) nv) and elements [k ntri, (k+1) ntri). Each capsule has a species; a
// species has a capillary number Ca, a bending modulus, a membrane law (with Skalak C), an inflation beta and a
// shape (sphere, spheroid, Evans-Fung biconcave disc: shapes.hpp). In the project's units (mu = gammadot_w = 1,
// length a) the shear modulus is Gs = radius / Ca, i.e. Gs = 1/Ca for a capsule of radius 1 (decision D1); the
// radius is per capsule (the equal-volume radius of its initial shape).
//
// A capsule starts as its species' shape (the icosphere mapped onto it, scaled to the radius, rotated by its
// orientation, centred); the reference (stress-free) shape is that shape scaled by 1/(1 + beta) about its centre
// (D7; beta = 0 makes the initial shape stress-free, as a red cell wants). A0 and the shape-function gradients are
// computed once, when the capsule is added. A sphere with the identity orientation gets exactly the nodes it got
// before shapes existed (center + radius * icosphere node), so such runs keep their bits.
//
// Usage:
//     CapsuleState s(2);                       // level-2 mesh; species defaults: neo-Hookean, inflation 0.1
//     int soft = s.add_species(0.3);           // Ca = 0.3, a sphere with the defaults
//     SpeciesProperties rbc{0.5, 0.02, {MembraneLaw::Skalak, 10.0, 0.0}, {ShapeKind::Biconcave}};
//     int red = s.add_species(rbc);
//     s.add_capsule({5, 2, 5}, 1.0, soft);
//     s.add_capsule({9, 2, 5}, 1.0, red, rotation_to_axis({0, 1, 0}));
//     s.compute_membrane_forces(Backend::Threads);   // fills s.fx, s.fy, s.fz (density on the fluid)
//     CapsuleGeometry g = compute_geometry(s, Backend::Serial);
#include <array>
#include <vector>

#include "host/state/icosphere.hpp"
#include "host/state/membrane_parameters.hpp"
#include "host/state/shapes.hpp"
#include "kernels/backend.hpp"
#include "kernels/bending_forces.hpp"
#include "kernels/membrane_forces.hpp"

namespace capsflow {


// What a species is made of (issue 23). Ca and bending_modulus as in add_species(Ca, kb); membrane: law, Skalak C
// and inflation beta; shape: the initial and (scaled by 1/(1 + beta)) reference shape.
struct SpeciesProperties {
  double Ca = 1.0;
  double bending_modulus = 0.0;
  MembraneParameters membrane;
  ShapeSpec shape;
};

// The bending kernel's view of a mesh's connectivity (raw pointers into m; m must outlive it).
BendingTopology bending_topology(const TriMesh& m);

class CapsuleState {
 public:
  // `params`: the membrane of species added by add_species(Ca, kb). Throws InputError for bad parameters.
  explicit CapsuleState(int mesh_level = 2, MembraneParameters params = {});

  // Adds a spherical species with capillary number Ca (> 0), bending modulus kb = kappa / (Gs a^2) (>= 0; 0: no
  // bending resistance) and the constructor's membrane; returns its index.
  int add_species(double Ca, double bending_modulus = 0.0);
  // Adds a species of any shape and membrane. Throws InputError for a bad value (naming it).
  int add_species(const SpeciesProperties& p);
  // Adds a capsule of `species`: its shape at equal-volume `radius`, turned by `orientation` (body -> lab), about
  // `center`; reference shape scaled by 1/(1 + beta). Returns the capsule index. Throws InputError for a bad
  // radius, species or orientation (not a rotation to 1e-12).
  int add_capsule(const std::array<double, 3>& center, double radius, int species,
                  const Rotation& orientation = kIdentityRotation);

  const TriMesh& mesh() const { return *mesh_; }
  const MembraneParameters& parameters() const { return params_; }  // the default species' membrane
  int num_species() const { return static_cast<int>(species_props_.size()); }
  const SpeciesProperties& species_properties(int species) const { return species_props_[species]; }
  int num_capsules() const { return static_cast<int>(species_.size()); }
  int nodes_per_capsule() const { return mesh_->num_nodes(); }
  int triangles_per_capsule() const { return mesh_->num_triangles(); }
  long num_nodes() const { return static_cast<long>(x.size()); }
  int species_of(int capsule) const { return species_[capsule]; }
  double capillary_number(int species) const { return species_props_[species].Ca; }
  double radius_of(int capsule) const { return radius_[capsule]; }
  const std::vector<double>& shear_modulus() const { return Gs_; }  // Gs per capsule
  const std::vector<MembraneLaw>& membrane_law() const { return law_; }  // per capsule
  const std::vector<double>& skalak_c() const { return Cs_; }            // per capsule (unused by neo-Hookean)
  // Helfrich bending rigidity kappa = kb Gs a^2 per capsule, and whether any capsule has one.
  const std::vector<double>& bending_rigidity() const { return kappa_; }
  bool has_bending() const { return has_bending_; }

  MeshTopology topology() const;
  BendingTopology bending_topology() const;
  MembraneReference reference() const;

  // Elastic forces at the current x, y, z, in-plane and (where kappa > 0) bending: fills F (nodal forces),
  // node_area and f (density on the fluid).
  // Checks the backend with require_backend().
  void compute_membrane_forces(Backend backend);
  // The in-plane part alone (physics/force_terms.hpp's ElasticForce, the run's first term): overwrites F,
  // node_area and f.
  void compute_in_plane_forces(Backend backend);
  // Adds the bending forces of the capsules with kappa > 0 to F and sets f = F / area (after membrane_forces).
  void add_bending_forces(Backend backend, double* Fx, double* Fy, double* Fz, const double* area, double* fx,
                          double* fy, double* fz) const;
  // Total elastic energy of each capsule, in-plane plus bending (serial).
  std::vector<double> membrane_energy() const;

  // Node positions (current), ncap * nv each. Callers may move nodes freely.
  std::vector<double> x, y, z;
  // Outputs of compute_membrane_forces.
  std::vector<double> Fx, Fy, Fz;      // elastic nodal force (-dE/dx)
  std::vector<double> node_area;       // lumped current nodal area
  std::vector<double> fx, fy, fz;      // density on the fluid: +F / node_area (pitfall P1)

 private:
  const TriMesh* mesh_;
  MembraneParameters params_;
  std::vector<int> species_;         // per capsule
  std::vector<double> radius_, Gs_;  // per capsule
  std::vector<MembraneLaw> law_;     // per capsule
  std::vector<double> Cs_;           // per capsule
  std::vector<SpeciesProperties> species_props_;
  // Per species: its shape at unit equal-volume radius (nv nodes each; the icosphere itself for spheres).
  std::vector<std::vector<double>> unit_x_, unit_y_, unit_z_;
  std::vector<double> kappa_;        // per capsule: bending rigidity
  bool has_bending_ = false;
  mutable std::vector<double> bend_edge_, bend_tri_, bend_node_;  // bending_forces scratch
  // Per-element reference data (ncap * ntri each).
  std::vector<double> area0_, g1x_, g1y_, g2x_, g2y_;
  std::vector<double> work_;  // 10 doubles per element (membrane_forces scratch)
};

// Per-node membrane fields for output (docs/output_format.md, format 5), from the current x, y, z alone: serial, and
// without touching the state's force arrays (on the device backend those live on the device between steps).
struct MembraneNodeFields {
  std::vector<double> traction_jump;  // 3 per node, interleaved: (sigma_out - sigma_in) n = -F_i / A_i
  // Per node: the elements' values averaged with their current areas as weights (the weights of the lumped A_i).
  std::vector<double> tension_max, tension_min;  // principal Cauchy tensions, force per current length
  std::vector<double> energy_density;            // W, energy per reference area
};
MembraneNodeFields membrane_node_fields(const CapsuleState& s);

// Taylor deformation of one capsule from its second moments about the centroid (m6 as in
// capsule_shape_moments). Semi-axes of the equivalent ellipsoid: a_i = sqrt(5 mu_i / V), mu_i the eigenvalues
// of M (equivalently proportional to sqrt(I_jj + I_kk - I_ii) of the inertia tensor I = tr(M) 1 - M).
struct TaylorDeformation {
  std::array<double, 3> semi_axes{};  // equivalent-ellipsoid semi-axes, descending
  double L = 0.0, B = 0.0;            // longest and shortest semi-axis in the shear (x-y) plane
  double D = 0.0;                     // (L - B) / (L + B)
  double inclination = 0.0;           // angle of the L axis from the x axis in the x-y plane, in (-pi/2, pi/2]
};
TaylorDeformation taylor_deformation(const double* m6, double volume);

struct CapsuleGeometry {
  std::vector<double> volume, area;          // per capsule
  std::vector<double> centroid;              // 3 per capsule
  std::vector<double> moments;               // 6 per capsule, about the centroid
  std::vector<TaylorDeformation> deformation;
  std::vector<double> min_edge;              // shortest edge per capsule
  double global_min_edge = 0.0;              // over all capsules (0 with no capsules)
};
CapsuleGeometry compute_geometry(const CapsuleState& s, Backend backend);

// Volume-averaged velocity (U) and mean rotation (omega), 3 per capsule, from node velocities u.
void compute_mean_velocity(const CapsuleState& s, Backend backend, const std::vector<double>& ux,
                           const std::vector<double>& uy, const std::vector<double>& uz, std::vector<double>& U,
                           std::vector<double>& omega);

// Area-weighted unit outward node normals of all capsules.
void compute_node_normals(const CapsuleState& s, Backend backend, std::vector<double>& nx, std::vector<double>& ny,
                          std::vector<double>& nz);

}  // namespace capsflow
