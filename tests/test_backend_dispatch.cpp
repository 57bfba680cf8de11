// Backend dispatch: every kernel entry refuses a backend this binary was not built for (a logic_error naming the
// kernel, never a silent no-op), and only the explicit test switch lets 'device' run on the host fallback.
#include <gtest/gtest.h>

#include <cstdlib>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "host/base/backend_select.hpp"
#include "host/base/errors.hpp"
#include "kernels/capsule_geometry.hpp"
#include "kernels/contact.hpp"
#include "kernels/local_double_layer.hpp"
#include "kernels/local_single_layer.hpp"
#include "kernels/local_sum.hpp"
#include "kernels/spread_interp.hpp"
#include "kernels/step_update.hpp"

using namespace capsflow;

namespace {

// Sets (or unsets, with nullopt) an environment variable for one scope and restores it after.
class EnvGuard {
 public:
  EnvGuard(const char* name, std::optional<std::string> value) : name_(name) {
    if (const char* old = std::getenv(name)) saved_ = old;
    if (value)
      ::setenv(name, value->c_str(), 1);
    else
      ::unsetenv(name);
  }
  ~EnvGuard() {
    if (saved_)
      ::setenv(name_, saved_->c_str(), 1);
    else
      ::unsetenv(name_);
  }

 private:
  const char* name_;
  std::optional<std::string> saved_;
};

constexpr const char* kSwitch = "CAPSFLOW_TEST_DEVICE_HOST_FALLBACK";

}  // namespace

TEST(KernelDispatch, EveryEntryRefusesTheDeviceInAHostBuild) {
  if (device_backend_built()) GTEST_SKIP() << "offload build: the device backend is built, nothing to refuse";
  // Empty inputs: the refusal must come first, before any early return on "nothing to do".
  std::vector<double> d(16, 0.0);
  double* p = d.data();
  const std::vector<int> ints(16, 0);
  const int* ip = ints.data();
  const double y[2] = {0.0, 1.0};
  const SlitGridView g{4, 4, 1, 0.25, 0.25, 1.0, y};
  SpreadWorkspace ws;
  const PointCellList pcl;
  const ElementCellList ecl;
  const MeshTopology mesh{};
  const PairGapLimits lim{};
  const std::vector<std::pair<const char*, std::function<void()>>> entries = {
      {"local_velocity_point_forces",
       [&] { local_velocity_point_forces(Backend::Device, pcl, 4.0, 0.9, 1.0, 0, p, p, p, p, p, p); }},
      {"local_single_layer_velocity",
       [&] {
         local_single_layer_velocity(Backend::Device, ecl, LocalSplit{4.0, 0.9, 1.0}, SurfaceView{0, 0, 0, ip, p, p, p},
                                     Vec3In{p, p, p}, QuadratureOrders{}, TargetView{0, p, p, p, nullptr},
                                     Vec3Out{p, p, p});
       }},
      {"spread_forces", [&] { spread_forces(Backend::Device, g, 4.0, 0.9, 0, p, p, p, p, p, p, p, p, p, ws); }},
      {"prepare_spread", [&] { prepare_spread(Backend::Device, g, 4.0, 0.9, 0, p, p, p, ws); }},
      {"spread_prepared", [&] { spread_prepared(Backend::Device, g, 4.0, 0.9, 0, p, p, p, p, p, p, p, p, p, ws); }},
      {"interpolate_velocity", [&] { interpolate_velocity(Backend::Device, g, p, p, p, 0, p, p, p, p, p, p); }},
      {"capsule_bounds", [&] { capsule_bounds(Backend::Device, 0, 0, p, p, p, p, p, p, p); }},
      {"pair_gaps",
       [&] { pair_gaps(Backend::Device, 0, mesh, Vec3In{p, p, p}, p, p, p, 0, ip, lim, 1.0, 1.0, p, p); }},
      {"pair_closing",
       [&] {
         pair_closing(Backend::Device, 0, mesh, Vec3In{p, p, p}, Vec3In{p, p, p}, p, p, 0, ip,
                      ClosingThresholds{1.0, 0.1}, 1.0, 1.0, p, p);
       }},
      {"wall_closing", [&] { wall_closing(Backend::Device, 0, 0, p, p, 1.0, 1.0, 0.1, p, p); }},
      {"local_double_layer_velocity",
       [&] {
         local_double_layer_velocity(Backend::Device, ecl, LocalSplit{4.0, 0.9, 1.0}, SurfaceView{0, 0, 0, ip, p, p, p},
                                     Vec3In{p, p, p}, QuadratureOrders{}, TargetView{0, p, p, p, nullptr},
                                     Vec3Out{p, p, p});
       }},
      {"local_double_layer_matrix",
       [&] {
         local_double_layer_matrix(Backend::Device, ecl, LocalSplit{4.0, 0.9, 1.0}, SurfaceView{0, 0, 0, ip, p, p, p},
                                   QuadratureOrders{}, TargetView{0, p, p, p, ip}, p);
       }},
      {"capsule_shape", [&] { capsule_shape(Backend::Device, 0, 0, 0, ip, p, p, p, p, p, p, p); }},
      {"capsule_mean_velocity",
       [&] { capsule_mean_velocity(Backend::Device, 0, 0, 0, ip, p, p, p, p, p, p, p, p); }},
      {"node_normals", [&] { node_normals(Backend::Device, 0, 0, ip, ip, ip, p, p, p, p, p, p); }},
      {"volume_gradient", [&] { volume_gradient(Backend::Device, 0, 0, ip, ip, ip, p, p, p, p, p, p); }},
      {"project_volume_rate", [&] { project_volume_rate(Backend::Device, 0, 0, p, p, p, p, p, p); }},
      {"min_edge_length", [&] { min_edge_length(Backend::Device, 0, 0, 0, ip, p, p, p, p); }},
      // The step's loops (kernels/step_update.hpp).
      {"fill3", [&] { fill3(Backend::Device, 0, 0.0, p, p, p); }},
      {"copy3", [&] { copy3(Backend::Device, 0, p, p, p, p, p, p); }},
      {"ab2_update", [&] { ab2_update(Backend::Device, 0, 1.0, 1.0, 0.0, p, p, p, p, p, p, p, p, p); }},
      {"add_imposed_flow_x", [&] { add_imposed_flow_x(Backend::Device, 0, kImposedShear, 1.0, 1.0, p, p); }},
      {"all_finite3", [&] { (void)all_finite3(Backend::Device, 0, p, p, p); }},
      {"first_outside", [&] { (void)first_outside(Backend::Device, 0, p, 0.0, 1.0); }},
      {"max_element_radius", [&] { (void)max_element_radius(Backend::Device, 0, 0, 0, ip, p, p, p); }},
      {"capsule_node_means", [&] { capsule_node_means(Backend::Device, 0, 0, p, p, p, p); }},
      {"translate_capsules", [&] { translate_capsules(Backend::Device, 0, 0, p, p, p, p); }},
      {"volume_correction_step",
       [&] { volume_correction_step(Backend::Device, 0, 0, p, p, p, p, p, p, p, p); }},
  };
  for (const auto& [name, call] : entries) {
    try {
      call();
      ADD_FAILURE() << name << " ran with backend 'device' in a host-only build";
    } catch (const std::logic_error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(name), std::string::npos) << what;
      EXPECT_NE(what.find("CAPSFLOW_OFFLOAD"), std::string::npos) << what;
    }
  }
  // The host backends run the same (empty) calls without complaint.
  EXPECT_NO_THROW(spread_forces(Backend::Serial, g, 4.0, 0.9, 0, p, p, p, p, p, p, p, p, p, ws));
  EXPECT_NO_THROW(interpolate_velocity(Backend::Threads, g, p, p, p, 0, p, p, p, p, p, p));
}

TEST(DeviceAvailability, OnlyTheTestSwitchAcceptsTheHostFallback) {
  const bool real_device = device_backend_built() && device_count() > 0;
  {
    const EnvGuard unset(kSwitch, std::nullopt);
    EXPECT_FALSE(device_host_fallback_for_tests());
    EXPECT_EQ(backend_available(Backend::Device), real_device);
    if (!real_device) {
      EXPECT_THROW(require_backend(Backend::Device), BackendUnavailable);
    }
  }
  {
    const EnvGuard other(kSwitch, std::string("yes"));  // only "1" switches it on
    EXPECT_FALSE(device_host_fallback_for_tests());
    EXPECT_EQ(backend_available(Backend::Device), real_device);
  }
  {
    const EnvGuard on(kSwitch, std::string("1"));
    // A host-only build has no device code to fall back to: the switch changes nothing there.
    EXPECT_EQ(device_host_fallback_for_tests(), device_backend_built());
    EXPECT_EQ(backend_available(Backend::Device), device_backend_built());
  }
}
