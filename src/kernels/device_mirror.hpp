#pragma once
// DeviceMirror: the one owner of the device copies of a run's arrays (architecture review R7; docs/device.md "Next").
//
// A mirror made for Backend::Device in an offload build maps each attached array once (`target enter data
// map(to:)`) and keeps it on the device until detach() or its destructor. push() and pull() copy one array each way
// (`target update`), only where something changed: after a host-side edit, and for output or checkpoints. While an
// array is attached, a kernel's `map` clause on the same host range finds it present and copies nothing (OpenMP's
// present rule), so today's kernels already run on the resident copy; kernels written for residency take the device
// address from device_ptr() (`is_device_ptr`). For the serial and threads backends, in host builds, and on the host
// fallback every call is a no-op: host and "device" copy are the same memory.
//
// Usage:
//     DeviceMirror m(backend);
//     m.attach(x.data(), x.size());          // once per run (and after a resize: detach, then attach)
//     ... kernels on x ...
//     m.pull(x.data(), x.size());            // before writing an output record
//     x[i] = ...; m.push(x.data(), x.size()); // after a host-side edit
#include <cstddef>
#include <vector>

#include "kernels/backend.hpp"

namespace capsflow {

class DeviceMirror {
 public:
  explicit DeviceMirror(Backend backend);
  ~DeviceMirror();
  DeviceMirror(const DeviceMirror&) = delete;
  DeviceMirror& operator=(const DeviceMirror&) = delete;

  // True when this mirror keeps device copies (Backend::Device in an offload build).
  bool active() const { return active_; }

  // Maps p[0:n] to the device and copies it there. Throws std::logic_error when p is already attached.
  void attach(double* p, std::size_t n) { attach_bytes(p, n * sizeof(double)); }
  // Copies host -> device / device -> host. Throw std::logic_error when (p, n) is not an attached array (a resized
  // vector has moved: detach it before the resize and attach it after).
  void push(const double* p, std::size_t n) { push_bytes(p, n * sizeof(double)); }
  void pull(double* p, std::size_t n) { pull_bytes(p, n * sizeof(double)); }
  // Unmaps p without copying back (pull first to keep the device's values).
  void detach(const void* p);

  // The same for any trivially copyable array (int mesh data, per-capsule flags), as a byte range: OpenMP finds a
  // later map clause's typed range present when it lies inside an attached byte range.
  void attach_bytes(const void* p, std::size_t bytes);
  void push_bytes(const void* p, std::size_t bytes);
  void pull_bytes(void* p, std::size_t bytes);
  // Device address of an attached array (p itself when inactive).
  double* device_ptr(double* p) const;
  std::size_t attached_count() const { return entries_.size(); }

 private:
  struct Entry {
    const void* p;
    std::size_t bytes;
  };
  const Entry& find(const void* p, std::size_t bytes, const char* what) const;

  bool active_ = false;
  std::vector<Entry> entries_;
};

}  // namespace capsflow
