#pragma once
// StepWorkspace: the one owner of the device copies of a run's step arrays on the device backend, with HOOMD's
// GPUArray data-location bookkeeping reduced to OpenMP (architecture review R7; docs/device.md "Resident data").
//
// Each registered array (node positions, AB2 history, forces and densities, velocities, volume gradients, wall
// data, mesh and membrane reference data, per-capsule data) is attached once per run through DeviceMirror and has a
// location: which copy is valid (host, device, or both). Code that touches an array says how, before it does:
//
//   host_read(v)        the host reads v:          pulls it if only the device copy is valid; then both are valid
//   host_write(v)       the host reads and writes: pulls it if needed; then only the host copy is valid
//   host_overwrite(v)   the host writes every entry without reading: no pull; then only the host copy is valid
//   device_read(v)      a kernel reads v:          pushes it if only the host copy is valid; then both are valid
//   device_write(v)     a kernel reads and writes: pushes it if needed; then only the device copy is valid
//   device_overwrite(v) a kernel writes every entry without reading: no push; then only the device copy is valid
//
// Each declaration hands out the array's pointer (HOOMD's ArrayHandle, UAMMD's getPos(location, mode)), so a kernel
// argument can be taken from the declaration instead of beside it.
//
// So a host read after a device write pulls exactly once, a device read after a host write pushes exactly once, and
// nothing moves while the needed copy is valid. Every transfer is counted (calls and bytes, by array name), so the
// tests can hold a step to its documented set of transfers. Kernels reach the device copy through their own map
// clauses, which find the attached range present and copy nothing (OpenMP's present rule), or through device_ptr.
//
// Inactive (a no-op with zero transfers) unless the backend is Backend::Device in an offload build. On the OpenMP
// host fallback (tests without a GPU) the bookkeeping and the counters run exactly as on a GPU; only the copies are
// identities there, since host and "device" memory are the same. So the fallback checks which transfers a step asks
// for, and only a GPU checks that the data really is where the bookkeeping says (docs/device.md).
//
// Arrays are keyed by their buffer address: a std::vector must not be resized while registered (checked: a
// registered address with another length is a std::logic_error); swap() exchanges two registered vectors together
// with their names, so a name keeps meaning the role (u^n, u^{n-1}) while the buffers change places.
//
// Usage:
//     StepWorkspace ws(backend);
//     ws.add(x, "x");                        // once per run, after the host values are final
//     ws.device_write(x); kernel(x.data());  // x now valid on the device only
//     ws.host_read(x); write_output(x);      // one pull
//     ws.transfers();                        // calls and bytes so far
#include <cstddef>
#include <string>
#include <vector>

#include "kernels/backend.hpp"
#include "kernels/device_mirror.hpp"

namespace capsflow {

enum class DataLocation { Host, Device, HostAndDevice };

struct TransferCounts {
  long push_calls = 0, pull_calls = 0;
  std::size_t push_bytes = 0, pull_bytes = 0;
  long scalar_results = 0;  // scalars returned by reductions on the device (check flags, minima): 8 bytes each
  long calls() const { return push_calls + pull_calls; }
};
TransferCounts operator-(const TransferCounts& a, const TransferCounts& b);

// One transfer, for tests and diagnostics.
struct TransferRecord {
  std::string name;
  bool to_device = false;
  std::size_t bytes = 0;
};

class StepWorkspace {
 public:
  explicit StepWorkspace(Backend backend);
  StepWorkspace(const StepWorkspace&) = delete;
  StepWorkspace& operator=(const StepWorkspace&) = delete;

  // True for Backend::Device in an offload build (also on the host fallback).
  bool active() const { return mirror_.active(); }

  // Registers and attaches an array (one copy to the device; both copies valid). `constant`: never written after
  // this (mesh, reference data); host_write/device_write on it is a logic error. No-op when inactive.
  template <class T>
  void add(std::vector<T>& v, const std::string& name) {
    add_range(v.data(), v.size() * sizeof(T), name, false);
  }
  template <class T>
  void add_constant(const std::vector<T>& v, const std::string& name) {
    add_range(v.data(), v.size() * sizeof(T), name, true);
  }
  void add_range(const void* p, std::size_t bytes, const std::string& name, bool constant);
  bool has(const void* p) const;

  template <class T>
  const T* host_read(const std::vector<T>& v) {
    access(v.data(), v.size() * sizeof(T), Side::Host, Mode::Read);
    return v.data();
  }
  template <class T>
  T* host_write(std::vector<T>& v) {
    access(v.data(), v.size() * sizeof(T), Side::Host, Mode::ReadWrite);
    return v.data();
  }
  template <class T>
  T* host_overwrite(std::vector<T>& v) {
    access(v.data(), v.size() * sizeof(T), Side::Host, Mode::Overwrite);
    return v.data();
  }
  template <class T>
  const T* device_read(const std::vector<T>& v) {
    access(v.data(), v.size() * sizeof(T), Side::Device, Mode::Read);
    return v.data();
  }
  template <class T>
  T* device_write(std::vector<T>& v) {
    access(v.data(), v.size() * sizeof(T), Side::Device, Mode::ReadWrite);
    return v.data();
  }
  template <class T>
  T* device_overwrite(std::vector<T>& v) {
    access(v.data(), v.size() * sizeof(T), Side::Device, Mode::Overwrite);
    return v.data();
  }

  // Exchanges two registered vectors (a.swap(b)) and their names; their locations travel with the buffers.
  template <class T>
  void swap(std::vector<T>& a, std::vector<T>& b) {
    a.swap(b);
    swap_names(a.data(), b.data());
  }

  // Which copy of a registered array is valid (HostAndDevice when inactive or unregistered).
  DataLocation location(const void* p) const;

  // A reduction's scalar result came back from the device (counted, not copied by the workspace).
  void note_scalar_results(long k) {
    if (active()) counts_.scalar_results += k;
  }
  const TransferCounts& transfers() const { return counts_; }
  // The transfers since the last clear_log() (the counters keep running).
  const std::vector<TransferRecord>& log() const { return log_; }
  void clear_log() const { log_.clear(); }
  std::size_t registered() const { return entries_.size(); }

 private:
  enum class Side { Host, Device };
  enum class Mode { Read, ReadWrite, Overwrite };
  struct Entry {
    const void* p;
    std::size_t bytes;
    std::string name;
    bool constant;
    DataLocation where;
  };
  Entry& find(const void* p, std::size_t bytes);
  void access(const void* p, std::size_t bytes, Side side, Mode mode);
  void swap_names(const void* a, const void* b);

  DeviceMirror mirror_;
  std::vector<Entry> entries_;
  TransferCounts counts_;
  mutable std::vector<TransferRecord> log_;  // diagnostics: clearing it changes no state
};

}  // namespace capsflow
