// StepWorkspace: the data-location bookkeeping of the device step (src/host/state/step_workspace.hpp). Each transition is
// checked by its transfer counts, which run on the host fallback exactly as on a GPU: a host read after a device
// write pulls once, a device read after a host write pushes once, nothing moves while the needed copy is valid. On
// the serial and threads backends the workspace is inactive: zero transfers whatever is declared. On a GPU the
// device instance also checks the data itself (a kernel's write is seen on the host only after the pull).
#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "host/state/step_workspace.hpp"
#include "support/backends.hpp"

using namespace capsflow;

namespace {

// p[i] = 2 p[i] + 1 in a target region whose map clause finds an attached array present (copies nothing).
void twice_plus_one(Backend b, double* p, std::size_t n) {
  const bool on_device = b == Backend::Device;
  const long long m = static_cast<long long>(n);
#ifdef CAPSFLOW_HAVE_OFFLOAD
#pragma omp target teams distribute parallel for map(tofrom : p[0:n]) if (target : on_device)
#else
  (void)on_device;
#endif
  for (long long i = 0; i < m; ++i) p[i] = 2.0 * p[i] + 1.0;
}

class StepWorkspaceTest : public test::OnEachBackend {
 protected:
  bool active() const { return backend() == Backend::Device; }
  // A separate device copy (a GPU, not the fallback).
  bool resident() const { return active() && device_count() > 0; }
  static constexpr std::size_t kN = 500;
  static constexpr std::size_t kBytes = kN * sizeof(double);
};

TEST_P(StepWorkspaceTest, DeviceWriteThenHostReadPullsExactlyOnce) {
  std::vector<double> v(kN, 1.0);
  StepWorkspace ws(backend());
  EXPECT_EQ(ws.active(), active());
  ws.add(v, "v");
  EXPECT_EQ(ws.location(v.data()), DataLocation::HostAndDevice);
  EXPECT_EQ(ws.transfers().calls(), 0) << "attaching is not a counted transfer";

  ws.device_write(v);  // both valid: no push
  twice_plus_one(backend(), v.data(), kN);
  EXPECT_EQ(ws.transfers().calls(), 0);
  if (active()) {
    EXPECT_EQ(ws.location(v.data()), DataLocation::Device);
  }
  if (resident()) {
    EXPECT_EQ(v[3], 1.0) << "the kernel's result reached the host without a pull: not resident";
  }

  ws.host_read(v);
  ws.host_read(v);  // valid now: no second pull
  EXPECT_EQ(ws.transfers().pull_calls, active() ? 1 : 0);
  EXPECT_EQ(ws.transfers().pull_bytes, active() ? kBytes : 0u);
  EXPECT_EQ(ws.transfers().push_calls, 0);
  EXPECT_EQ(v[3], 3.0);
  if (active()) {
    EXPECT_EQ(ws.location(v.data()), DataLocation::HostAndDevice);
    ASSERT_EQ(ws.log().size(), 1u);
    EXPECT_EQ(ws.log()[0].name, "v");
    EXPECT_FALSE(ws.log()[0].to_device);
    EXPECT_EQ(ws.log()[0].bytes, kBytes);
  }
  ws.device_read(v);  // both valid: nothing moves
  EXPECT_EQ(ws.transfers().calls(), active() ? 1 : 0);
}

TEST_P(StepWorkspaceTest, HostWriteThenDeviceReadPushesExactlyOnce) {
  std::vector<double> v(kN, 1.0);
  StepWorkspace ws(backend());
  ws.add(v, "v");
  ws.host_overwrite(v);  // no pull: every entry is written
  for (double& a : v) a = 5.0;
  EXPECT_EQ(ws.transfers().calls(), 0);
  if (active()) {
    EXPECT_EQ(ws.location(v.data()), DataLocation::Host);
  }
  ws.device_read(v);
  ws.device_read(v);
  EXPECT_EQ(ws.transfers().push_calls, active() ? 1 : 0);
  EXPECT_EQ(ws.transfers().push_bytes, active() ? kBytes : 0u);
  ws.device_write(v);  // valid on the device: no second push
  twice_plus_one(backend(), v.data(), kN);
  EXPECT_EQ(ws.transfers().push_calls, active() ? 1 : 0);
  ws.host_write(v);  // read-write on the host: one pull, then only the host copy is valid
  EXPECT_EQ(ws.transfers().pull_calls, active() ? 1 : 0);
  EXPECT_EQ(v[0], 11.0);
  if (active()) {
    EXPECT_EQ(ws.location(v.data()), DataLocation::Host);
  }
}

TEST_P(StepWorkspaceTest, OverwritesMoveNothing) {
  std::vector<double> v(kN, 0.0);
  StepWorkspace ws(backend());
  ws.add(v, "v");
  for (int k = 0; k < 3; ++k) {
    ws.device_overwrite(v);
    ws.host_overwrite(v);
  }
  EXPECT_EQ(ws.transfers().calls(), 0);
}

TEST_P(StepWorkspaceTest, SwapKeepsNamesWithRolesAndLocationsWithBuffers) {
  std::vector<double> a(kN, 1.0), b(kN, 2.0);
  StepWorkspace ws(backend());
  ws.add(a, "a");
  ws.add(b, "b");
  ws.device_overwrite(b);  // b's buffer: device only
  const double* b_buffer = b.data();
  ws.swap(a, b);
  EXPECT_EQ(a.data(), b_buffer);
  if (active()) {
    EXPECT_EQ(ws.location(a.data()), DataLocation::Device);
    EXPECT_EQ(ws.location(b.data()), DataLocation::HostAndDevice);
  }
  ws.host_read(a);
  if (active()) {
    ASSERT_EQ(ws.log().size(), 1u);
    EXPECT_EQ(ws.log()[0].name, "a") << "the name follows the vector, not the buffer";
  }
}

TEST_P(StepWorkspaceTest, MisuseIsALogicErrorOnTheDeviceAndIgnoredElsewhere) {
  std::vector<double> v(kN, 0.0), u(kN, 0.0);
  std::vector<int> mesh(30, 1);
  StepWorkspace ws(backend());
  ws.add(v, "v");
  ws.add_constant(mesh, "mesh");
  if (!active()) {
    EXPECT_EQ(ws.registered(), 0u);
    EXPECT_NO_THROW(ws.host_read(u));
    return;
  }
  EXPECT_EQ(ws.registered(), 2u);
  EXPECT_THROW(ws.add(v, "again"), std::logic_error);
  EXPECT_THROW(ws.host_read(u), std::logic_error);       // never registered
  EXPECT_THROW(ws.device_write(mesh), std::logic_error);  // constant
  EXPECT_NO_THROW(ws.device_read(mesh));
  const double* p = v.data();
  v.resize(kN / 2);  // shrinking keeps the buffer: a different length at a registered address
  ASSERT_EQ(v.data(), p);
  EXPECT_THROW(ws.host_read(v), std::logic_error);
  v.resize(kN);
}

TEST_P(StepWorkspaceTest, ScalarResultsAreCountedOnlyOnTheDevice) {
  StepWorkspace ws(backend());
  ws.note_scalar_results(3);
  EXPECT_EQ(ws.transfers().scalar_results, active() ? 3 : 0);
}

CAPSFLOW_ON_EACH_BACKEND(StepWorkspaceTest);

}  // namespace
