#include "kernels/device_mirror.hpp"

#include <stdexcept>
#include <string>

#include "kernels/dispatch.hpp"

namespace capsflow {

DeviceMirror::DeviceMirror(Backend backend) {
  require_built(backend, "DeviceMirror");
#ifdef CAPSFLOW_HAVE_OFFLOAD
  active_ = backend == Backend::Device;
#endif
}

DeviceMirror::~DeviceMirror() {
  while (!entries_.empty()) detach(entries_.back().p);
}

const DeviceMirror::Entry& DeviceMirror::find(const double* p, std::size_t n, const char* what) const {
  for (const Entry& e : entries_)
    if (e.p == p && e.n == n) return e;
  throw std::logic_error(std::string("DeviceMirror::") + what +
                         ": the array is not attached with this address and length (a resized vector moves: detach "
                         "it before the resize, attach it after)");
}

void DeviceMirror::attach(double* p, std::size_t n) {
  for (const Entry& e : entries_)
    if (e.p == p) throw std::logic_error("DeviceMirror::attach: the array is already attached");
  entries_.push_back({p, n});
  if (!active_ || n == 0) return;
#ifdef CAPSFLOW_HAVE_OFFLOAD
#pragma omp target enter data map(to : p[0:n])
#endif
}

void DeviceMirror::push(const double* p, std::size_t n) {
  (void)find(p, n, "push");
  if (!active_ || n == 0) return;
#ifdef CAPSFLOW_HAVE_OFFLOAD
#pragma omp target update to(p[0:n])
#endif
}

void DeviceMirror::pull(double* p, std::size_t n) {
  (void)find(p, n, "pull");
  if (!active_ || n == 0) return;
#ifdef CAPSFLOW_HAVE_OFFLOAD
#pragma omp target update from(p[0:n])
#endif
}

void DeviceMirror::detach(double* p) {
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    if (entries_[i].p != p) continue;
    const std::size_t n = entries_[i].n;
    entries_.erase(entries_.begin() + static_cast<std::ptrdiff_t>(i));
    if (!active_ || n == 0) return;
#ifdef CAPSFLOW_HAVE_OFFLOAD
#pragma omp target exit data map(release : p[0:n])
#endif
    return;
  }
  throw std::logic_error("DeviceMirror::detach: the array is not attached");
}

double* DeviceMirror::device_ptr(double* p) const {
  for (const Entry& e : entries_) {
    if (e.p != p) continue;
    if (!active_ || e.n == 0) return p;
#ifdef CAPSFLOW_HAVE_OFFLOAD
    double* q = p;
    // GCC 12 has no omp_get_mapped_ptr: use_device_ptr translates the present host address.
#pragma omp target data use_device_ptr(q)
    { p = q; }
#endif
    return p;
  }
  throw std::logic_error("DeviceMirror::device_ptr: the array is not attached");
}

}  // namespace capsflow
