// DeviceMirror: attached arrays stay on the device until pulled. On a GPU the kernel below sees the device copy, not
// a host edit made after attach (that is residency); on the host backends and the host fallback host and device copy
// are the same memory. Each test states both outcomes, so the device instance checks real residency on a GPU
// (tools/device-check.sh) and the mirror's bookkeeping everywhere.
#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "kernels/device_mirror.hpp"
#include "support/backends.hpp"

using namespace capsflow;

namespace {

// p[i] += 1 in a target region whose map clause finds an attached array present (no copy either way).
void add_one(Backend b, double* p, std::size_t n) {
  const bool on_device = b == Backend::Device;
  const long long m = static_cast<long long>(n);
#ifdef CAPSFLOW_HAVE_OFFLOAD
#pragma omp target teams distribute parallel for map(tofrom : p[0:n]) if (target : on_device)
#else
  (void)on_device;  // host builds: no target regions (GCC would compile them for an installed offload compiler)
#endif
  for (long long i = 0; i < m; ++i) p[i] += 1.0;
}

// Same, on the device address from device_ptr (the form of kernels written for residency).
void add_one_device_ptr(Backend b, double* d, std::size_t n) {
  const bool on_device = b == Backend::Device;
  const long long m = static_cast<long long>(n);
#ifdef CAPSFLOW_HAVE_OFFLOAD
#pragma omp target teams distribute parallel for is_device_ptr(d) if (target : on_device)
#else
  (void)on_device;
#endif
  for (long long i = 0; i < m; ++i) d[i] += 1.0;
}

class DeviceMirrorTest : public test::OnEachBackend {
 protected:
  // True where the mirror keeps a separate copy on a GPU.
  bool resident() const { return backend() == Backend::Device && device_count() > 0; }
};

TEST_P(DeviceMirrorTest, KernelsSeeTheDeviceCopyUntilPushAndPull) {
  const std::size_t n = 1000;
  std::vector<double> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<double>(i);
  DeviceMirror m(backend());
  EXPECT_EQ(m.active(), backend() == Backend::Device);
  m.attach(v.data(), n);
  EXPECT_EQ(m.attached_count(), 1u);
  for (std::size_t i = 0; i < n; ++i) v[i] = 2.0 * static_cast<double>(i);  // host edit, not pushed
  add_one(backend(), v.data(), n);
  if (resident()) {
    EXPECT_EQ(v[7], 14.0) << "the kernel's map clause copied back: the array was not resident";
  }
  m.pull(v.data(), n);
  for (std::size_t i = 0; i < n; ++i) {
    // GPU: the device copy was made at attach (i) and the host edit never reached it; elsewhere one array.
    const double expect = resident() ? static_cast<double>(i) + 1.0 : 2.0 * static_cast<double>(i) + 1.0;
    ASSERT_EQ(v[i], expect) << "element " << i;
  }
  for (std::size_t i = 0; i < n; ++i) v[i] = -static_cast<double>(i);
  m.push(v.data(), n);
  add_one_device_ptr(backend(), m.device_ptr(v.data()), n);
  m.pull(v.data(), n);
  for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(v[i], 1.0 - static_cast<double>(i)) << "element " << i;
  m.detach(v.data());
  EXPECT_EQ(m.attached_count(), 0u);
}

TEST_P(DeviceMirrorTest, MisuseIsALogicError) {
  std::vector<double> v(10, 1.0), w(10, 2.0);
  DeviceMirror m(backend());
  m.attach(v.data(), v.size());
  EXPECT_THROW(m.attach(v.data(), v.size()), std::logic_error);  // twice
  EXPECT_THROW(m.push(w.data(), w.size()), std::logic_error);    // never attached
  EXPECT_THROW(m.pull(v.data(), 5), std::logic_error);           // another length (a resize)
  EXPECT_THROW(m.detach(w.data()), std::logic_error);
  EXPECT_THROW((void)m.device_ptr(w.data()), std::logic_error);
}  // the destructor detaches v

CAPSFLOW_ON_EACH_BACKEND(DeviceMirrorTest);

}  // namespace
