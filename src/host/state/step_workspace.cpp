// The implementation of step_workspace.hpp: StepWorkspace, the owner of a run's step arrays on the device.
#include "host/state/step_workspace.hpp"

#include <stdexcept>
#include <utility>

namespace capsflow {

TransferCounts operator-(const TransferCounts& a, const TransferCounts& b) {
  TransferCounts d;
  d.push_calls = a.push_calls - b.push_calls;
  d.pull_calls = a.pull_calls - b.pull_calls;
  d.push_bytes = a.push_bytes - b.push_bytes;
  d.pull_bytes = a.pull_bytes - b.pull_bytes;
  d.scalar_results = a.scalar_results - b.scalar_results;
  return d;
}

StepWorkspace::StepWorkspace(Backend backend) : mirror_(backend) {}

void StepWorkspace::add_range(const void* p, std::size_t bytes, const std::string& name, bool constant) {
  if (!active()) return;
  if (has(p)) throw std::logic_error("StepWorkspace::add: '" + name + "' is already registered");
  mirror_.attach_bytes(p, bytes);  // the attach copies the host values: both copies valid
  entries_.push_back({p, bytes, name, constant, DataLocation::HostAndDevice});
}

bool StepWorkspace::has(const void* p) const {
  for (const Entry& e : entries_)
    if (e.p == p) return true;
  return false;
}

StepWorkspace::Entry& StepWorkspace::find(const void* p, std::size_t bytes) {
  for (Entry& e : entries_) {
    if (e.p != p) continue;
    if (e.bytes != bytes)
      throw std::logic_error("StepWorkspace: '" + e.name + "' was resized while registered (" +
                             std::to_string(e.bytes) + " bytes registered, " + std::to_string(bytes) + " now)");
    return e;
  }
  throw std::logic_error("StepWorkspace: an array of " + std::to_string(bytes) +
                         " bytes is not registered (a resized vector moves: register it at its final size)");
}

DataLocation StepWorkspace::location(const void* p) const {
  for (const Entry& e : entries_)
    if (e.p == p) return e.where;
  return DataLocation::HostAndDevice;
}

void StepWorkspace::access(const void* p, std::size_t bytes, Side side, Mode mode) {
  if (!active()) return;
  Entry& e = find(p, bytes);
  if (e.constant && mode != Mode::Read)
    throw std::logic_error("StepWorkspace: '" + e.name + "' is registered as constant and must not be written");
  const bool host = side == Side::Host;
  const DataLocation mine = host ? DataLocation::Host : DataLocation::Device;
  const DataLocation other = host ? DataLocation::Device : DataLocation::Host;
  // Overwrite needs no valid copy here; Read and ReadWrite copy from the other side when only it is valid.
  if (mode != Mode::Overwrite && e.where == other) {
    if (host) {
      mirror_.pull_bytes(const_cast<void*>(p), bytes);
      ++counts_.pull_calls;
      counts_.pull_bytes += bytes;
    } else {
      mirror_.push_bytes(p, bytes);
      ++counts_.push_calls;
      counts_.push_bytes += bytes;
    }
    log_.push_back({e.name, !host, bytes});
    e.where = DataLocation::HostAndDevice;
  }
  e.where = mode == Mode::Read ? (e.where == mine ? mine : DataLocation::HostAndDevice) : mine;
}

void StepWorkspace::swap_names(const void* a, const void* b) {
  if (!active() || a == b) return;
  Entry *ea = nullptr, *eb = nullptr;
  for (Entry& e : entries_) {
    if (e.p == a) ea = &e;
    if (e.p == b) eb = &e;
  }
  if (ea == nullptr || eb == nullptr) throw std::logic_error("StepWorkspace::swap: both arrays must be registered");
  std::swap(ea->name, eb->name);
}

}  // namespace capsflow
