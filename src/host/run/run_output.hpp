#pragma once
// RunOutput: writes OUT.h5 (layout in run_layout.hpp) and its ParaView index OUT.xdmf for a running Simulation.
// Every record and frame is flushed, so a killed run leaves a readable file up to its last record. A continued
// run (restart) opens the existing file, checks that it belongs to the checkpoint's run, drops what was written
// after the checkpoint and appends again, identically; it keeps the file's format version.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "host/run/checkpoint.hpp"
#include "host/base/h5_file.hpp"
#include "host/run/run_layout.hpp"
#include "host/physics/simulation.hpp"
#include "host/run/xdmf_writer.hpp"

namespace capsflow {

class RunOutput {
 public:
  // A new output (create = true; refuses an existing file unless force) or the continuation of one.
  RunOutput(const RunPaths& paths, const Simulation& sim, const std::string& run_id, bool create, bool force,
            const OutputSchedule& sched);

  std::int64_t format_version() const { return version_; }
  // Continuing: the output could not be truncated in place (a flush that failed on a full disk left its index
  // pointing past the end of the file) and was rebuilt from what the checkpoint covers (docs/output_format.md).
  bool repaired() const { return repaired_; }
  // One series record at the current (evaluated) state; fd is sim.flow_diagnostics(), computed once by the caller
  // (it also feeds the run summary).
  void record(const Simulation& sim, const FlowDiagnostics& fd);
  void frame(const Simulation& sim);   // one mesh frame (and the XDMF index)
  // A new run started from frame `frame` (strain `strain`) of the output `file` (--from): root attributes that say so
  // (frame_start.hpp's kAttrStartedFrom...); written before the first record, which flushes them.
  void set_start(const std::string& file, std::size_t frame, double strain);
  // Contact events of the steps since the last call (Simulation::take_events); returns how many were written.
  std::size_t events(const std::vector<ContactEventRecord>& ev);
  void close();

 private:
  void write_static(const Simulation& sim, const std::string& run_id);
  // A continued finished output (compressed series): made plain again before its first append.
  void unseal();
  template <class T>
  void append(const layout::DatasetInfo& d, const T* data, const std::vector<std::size_t>& inner);

  RunPaths paths_;
  std::int64_t version_ = layout::kFormatVersion;
  bool repaired_ = false;
  bool sealed_ = false;
  std::optional<H5File> h5_;
  std::unique_ptr<XdmfWriter> xdmf_;
  std::int64_t records_ = 0;
};

// Compresses the series, events and frame times of a finished output (the datasets a running output appends to record
// by record, and keeps plain so that a kill cannot tear what a checkpoint covers: docs/output_format.md, "Compression
// and size"): the file is copied into a new one with these datasets re-chunked, shuffled and deflated at `level`, the
// frames' chunks copied as they are, and the copy replaces `h5` atomically (a failure leaves `h5` as it was). Returns
// false, changing nothing, when `level` is 0 or the series are compressed already. A restart that continues the file
// makes its series plain again (RunOutput).
bool compress_finished_output(const std::filesystem::path& h5, int level);

}  // namespace capsflow
