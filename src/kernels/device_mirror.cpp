// The implementation of device_mirror.hpp: DeviceMirror, the owner of the device copies of a run's arrays.
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

const DeviceMirror::Entry& DeviceMirror::find(const void* p, std::size_t bytes, const char* what) const {
  for (const Entry& e : entries_)
    if (e.p == p && e.bytes == bytes) return e;
  throw std::logic_error(std::string("DeviceMirror::") + what +
                         ": the array is not attached with this address and length (a resized vector moves: detach "
                         "it before the resize, attach it after)");
}

// Byte ranges: `char` sections map any trivially copyable array; presence is by address range.
void DeviceMirror::attach_bytes(const void* p, std::size_t bytes) {
  for (const Entry& e : entries_)
    if (e.p == p) throw std::logic_error("DeviceMirror::attach: the array is already attached");
  entries_.push_back({p, bytes});
  if (!active_ || bytes == 0) return;
#ifdef CAPSFLOW_HAVE_OFFLOAD
  char* c = static_cast<char*>(const_cast<void*>(p));
#pragma omp target enter data map(to : c[0:bytes])
  (void)c;  // GCC 12 does not count a use in a standalone directive's clause
#endif
}

void DeviceMirror::push_bytes(const void* p, std::size_t bytes) {
  (void)find(p, bytes, "push");
  if (!active_ || bytes == 0) return;
#ifdef CAPSFLOW_HAVE_OFFLOAD
  char* c = static_cast<char*>(const_cast<void*>(p));
#pragma omp target update to(c[0:bytes])
  (void)c;  // GCC 12 does not count a use in a standalone directive's clause
#endif
}

void DeviceMirror::pull_bytes(void* p, std::size_t bytes) {
  (void)find(p, bytes, "pull");
  if (!active_ || bytes == 0) return;
#ifdef CAPSFLOW_HAVE_OFFLOAD
  char* c = static_cast<char*>(p);
#pragma omp target update from(c[0:bytes])
  (void)c;  // GCC 12 does not count a use in a standalone directive's clause
#endif
}

void DeviceMirror::detach(const void* p) {
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    if (entries_[i].p != p) continue;
    const std::size_t bytes = entries_[i].bytes;
    entries_.erase(entries_.begin() + static_cast<std::ptrdiff_t>(i));
    if (!active_ || bytes == 0) return;
#ifdef CAPSFLOW_HAVE_OFFLOAD
    char* c = static_cast<char*>(const_cast<void*>(p));
#pragma omp target exit data map(release : c[0:bytes])
  (void)c;  // GCC 12 does not count a use in a standalone directive's clause
#endif
    return;
  }
  throw std::logic_error("DeviceMirror::detach: the array is not attached");
}

double* DeviceMirror::device_ptr(double* p) const {
  for (const Entry& e : entries_) {
    if (e.p != p) continue;
    if (!active_ || e.bytes == 0) return p;
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
