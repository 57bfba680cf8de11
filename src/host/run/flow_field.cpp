// The fluid velocity of a frame at points of the slit (flow_field.hpp): the targets, the evaluation through the
// run's Simulation, and the FLOW.h5 / FLOW.xdmf files.
#include "host/run/flow_field.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <ostream>
#include <sstream>
#include <utility>

#include "capsflow_version.hpp"
#include "host/base/atomic_file.hpp"
#include "host/base/csv_io.hpp"
#include "host/base/errors.hpp"
#include "host/base/h5_file.hpp"
#include "host/physics/simulation.hpp"
#include "host/physics/velocity_model.hpp"
#include "kernels/step_update.hpp"

namespace capsflow {

namespace fs = std::filesystem;

namespace {

// A bound on the grid a mistyped --spacing could ask for (16 million points: ~1.5 GB of arrays).
constexpr std::size_t kMaxPoints = std::size_t{1} << 24;

const char* const kAxisName[3] = {"x", "y", "z"};

// Whole steps of about `spacing` over [0, L]: the count of points with both ends.
std::size_t points_over(double L, double spacing) {
  const double steps = std::max(1.0, std::round(L / spacing));
  return static_cast<std::size_t>(steps) + 1;
}

}  // namespace

FlowTargets plane_targets(const Config& cfg, const std::string& spec, double spacing) {
  const std::string want = "expected x=V, y=V or z=V (V a finite number, 0 <= V <= H for y), got '" + spec + "'";
  if (spec.size() < 3 || spec[1] != '=' || (spec[0] != 'x' && spec[0] != 'y' && spec[0] != 'z'))
    throw InputError("--plane: " + want);
  char* end = nullptr;
  const double v = std::strtod(spec.c_str() + 2, &end);
  const int axis = spec[0] - 'x';
  const double L[3] = {cfg.domain.Lx, cfg.domain.H, cfg.domain.Lz};
  if (end == spec.c_str() + 2 || *end != '\0' || !std::isfinite(v) || (axis == 1 && (v < 0.0 || v > L[1])))
    throw InputError("--plane: " + want + " (H = " + std::to_string(L[1]) + ")");
  if (!(spacing > 0.0) || !std::isfinite(spacing)) throw InputError("--spacing: expected a finite number > 0");
  FlowTargets t;
  t.plane = spec;
  t.axis = axis;
  t.value = v;
  t.axis_u = axis == 0 ? 2 : 0;  // the flow direction x across, where it lies in the plane
  t.axis_v = axis == 1 ? 2 : 1;
  t.nu = points_over(L[t.axis_u], spacing);
  t.nv = points_over(L[t.axis_v], spacing);
  if (static_cast<double>(t.nu) * static_cast<double>(t.nv) > static_cast<double>(kMaxPoints))
    throw InputError("--spacing: " + std::to_string(spacing) + " gives " + std::to_string(t.nu) + " x " +
                     std::to_string(t.nv) + " points, more than " + std::to_string(kMaxPoints) + ": expected a coarser one");
  std::vector<double>* out[3] = {&t.x, &t.y, &t.z};
  for (std::size_t j = 0; j < t.nv; ++j)
    for (std::size_t i = 0; i < t.nu; ++i) {
      out[t.axis]->push_back(v);
      out[t.axis_u]->push_back(L[t.axis_u] * static_cast<double>(i) / static_cast<double>(t.nu - 1));
      out[t.axis_v]->push_back(L[t.axis_v] * static_cast<double>(j) / static_cast<double>(t.nv - 1));
    }
  return t;
}

FlowTargets point_targets(TargetPoints p, double H, const std::string& csv) {
  validate_in_slit(p, H, csv);
  if (p.size() == 0) throw InputError(csv + ": expected at least one point (rows x,y,z after the header)");
  FlowTargets t;
  t.x = std::move(p.x);
  t.y = std::move(p.y);
  t.z = std::move(p.z);
  t.nu = t.x.size();
  return t;
}

FlowField frame_flow(const FrameStart& f, const Config& cfg, FlowTargets targets) {
  Simulation sim(cfg, f.state, f.file + ": ");
  const std::vector<double>& pos = f.state.positions;
  // Points that are nodes, bit for bit: their own elements take the singular rule, as in the solver.
  std::map<std::array<double, 3>, int> node_at;
  for (std::size_t i = 0; 3 * i < pos.size(); ++i)
    node_at.emplace(std::array<double, 3>{pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]}, static_cast<int>(i));
  FlowField u;
  u.at = std::move(targets);
  const std::size_t n = u.at.size();
  std::vector<int> node(n, -1);
  for (std::size_t p = 0; p < n; ++p) {
    const auto it = node_at.find({u.at.x[p], u.at.y[p], u.at.z[p]});
    if (it != node_at.end()) node[p] = it->second, ++u.nodes_matched;
  }
  for (auto* v : {&u.ux, &u.uy, &u.uz}) v->resize(n);
  u.capsule.resize(n);
  sim.fluid_velocity_at(n, u.at.x.data(), u.at.y.data(), u.at.z.data(), node.data(), u.ux.data(), u.uy.data(),
                        u.uz.data(), u.capsule.data());
  const int code = imposed_flow_code(cfg.flow.type);
  u.dx.resize(n);
  for (std::size_t p = 0; p < n; ++p)
    u.dx[p] = u.ux[p] - imposed_flow_x(code, cfg.flow.shear_rate, cfg.domain.H, u.at.y[p]);
  u.dy = u.uy;  // the imposed flow is along x
  u.dz = u.uz;
  return u;
}

namespace {

std::vector<double> interleave(const std::vector<double>& a, const std::vector<double>& b,
                               const std::vector<double>& c) {
  std::vector<double> v(3 * a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    v[3 * i] = a[i];
    v[3 * i + 1] = b[i];
    v[3 * i + 2] = c[i];
  }
  return v;
}

}  // namespace

void write_flow_h5(const fs::path& path, const FlowField& u, const FrameStart& f, const Config& cfg) {
  const std::size_t n = u.at.size();
  write_checkpoint_atomically(path, [&](H5File& h) {
    h.set_attribute("/", "format", std::string("capsflow-flow"));
    h.set_attribute("/", "format_version", std::int64_t{1});
    h.set_attribute("/", "capsflow_version", std::string(CAPSFLOW_VERSION_STRING));
    h.set_attribute("/", "source", fs::absolute(f.file).string());
    h.set_attribute("/", "frame", static_cast<std::int64_t>(f.frame));
    h.set_attribute("/", "strain", f.strain);
    h.set_attribute("/", "plane", u.at.plane);
    if (u.at.axis >= 0) {
      h.set_attribute("/", "axis", std::string(kAxisName[u.at.axis]));
      h.set_attribute("/", "axis_u", std::string(kAxisName[u.at.axis_u]));
      h.set_attribute("/", "axis_v", std::string(kAxisName[u.at.axis_v]));
      h.set_attribute("/", "value", u.at.value);
    }
    h.set_attribute("/", "nu", static_cast<std::int64_t>(u.at.nu));
    h.set_attribute("/", "nv", static_cast<std::int64_t>(u.at.nv));
    h.set_attribute("/", "H", cfg.domain.H);
    h.set_attribute("/", "Lx", cfg.domain.Lx);
    h.set_attribute("/", "Lz", cfg.domain.Lz);
    h.write_string("/parameters/config", to_toml(cfg));
    const std::vector<std::pair<const char*, std::vector<double>>> vec = {
        {"/points", interleave(u.at.x, u.at.y, u.at.z)},
        {"/velocity", interleave(u.ux, u.uy, u.uz)},
        {"/disturbance", interleave(u.dx, u.dy, u.dz)}};
    const char* units[3] = {"a", "gammadot a", "gammadot a"};
    for (std::size_t k = 0; k < vec.size(); ++k) {
      h.write<double>(vec[k].first, {n, 3}, vec[k].second);
      h.set_attribute(vec[k].first, "units", std::string(units[k]));
    }
    std::vector<std::int32_t> cap(u.capsule.begin(), u.capsule.end());
    h.write<std::int32_t>("/capsule", {n}, cap);
    h.set_attribute("/capsule", "units", std::string("1"));
    if (u.at.axis < 0) {  // the points' vertex cells for the XDMF index
      std::vector<std::int32_t> ids(n);
      for (std::size_t p = 0; p < n; ++p) ids[p] = static_cast<std::int32_t>(p);
      h.write<std::int32_t>("/vertices", {n}, ids);
      h.set_attribute("/vertices", "units", std::string("1"));
    }
  });
}

void write_flow_xdmf(const fs::path& path, const fs::path& h5, const FlowField& u) {
  const std::size_t n = u.at.size();
  const std::string file = h5.filename().string();
  std::ostringstream x;
  x << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n  <Grid Name=\"flow\" GridType=\"Uniform\">\n";
  if (u.at.axis >= 0)  // a structured surface: nv rows of nu points, the arrays' order (Dimensions slowest first)
    x << "   <Topology TopologyType=\"3DSMesh\" Dimensions=\"1 " << u.at.nv << " " << u.at.nu << "\"/>\n";
  else  // one vertex cell per point (/vertices: 0..N-1), so that filters that take cells see them
    x << "   <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << n
      << "\" NodesPerElement=\"1\">\n    <DataItem Dimensions=\"" << n
      << "\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">" << file << ":/vertices</DataItem>\n   </Topology>\n";
  x << "   <Geometry GeometryType=\"XYZ\">\n    <DataItem Dimensions=\"" << n
    << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << file << ":/points</DataItem>\n   </Geometry>\n";
  for (const char* name : {"velocity", "disturbance"})
    x << "   <Attribute Name=\"" << name << "\" AttributeType=\"Vector\" Center=\"Node\">\n    <DataItem Dimensions=\""
      << n << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << file << ":/" << name
      << "</DataItem>\n   </Attribute>\n";
  x << "   <Attribute Name=\"capsule\" AttributeType=\"Scalar\" Center=\"Node\">\n    <DataItem Dimensions=\"" << n
    << "\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">" << file << ":/capsule</DataItem>\n   </Attribute>\n";
  x << "  </Grid>\n </Domain>\n</Xdmf>\n";
  write_file_atomically(path, x.str());
}

}  // namespace capsflow
