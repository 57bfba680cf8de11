#pragma once
// The marker of a live run, OUT.lock beside OUT.h5 (RunPaths::lock): who is writing the output and when it last
// made progress. `capsflow run` writes it before it creates or reopens OUT.h5, refreshes it while it steps (the
// heartbeat, at most once a second), and removes it when it returns (end, early stop or signal, all with a
// checkpoint; also on an error, a refusal and exit() from a library). A marker left behind therefore means a process
// that died (kill -9, node failure, power loss). Two uses:
//   - a start (or restart) refuses an output that a live run is writing, whatever --force says;
//   - a new start that finds the leftovers of a start that died before its first checkpoint (the marker, and an
//     OUT.h5 that is unreadable or carries the marker's run id) replaces them instead of refusing (issue 13);
//   - `capsflow sweep --status` tells a running run from a killed one.
// A process on this host is live while its pid exists with the start time recorded in the marker (a reused pid
// does not count). On another host (a cluster's compute node seen from the login node) only the heartbeat's age
// tells: a marker refreshed within kStaleSeconds counts as live, except that a marker of this process's own Slurm
// job is dead (Slurm runs one instance of a job at a time: the marker is that of the job's earlier run, on a node
// that failed, before the job was requeued).
//
// Format: a JSON object {"run_id", "host", "pid", "start_ticks", "started", "heartbeat", "strain", "end",
// "slurm_job"}, times in seconds since the Unix epoch, every number in the shortest text that reads back to the same
// double. The reader also takes the `key = value` lines written before 2026-12-07.
#include <filesystem>
#include <optional>
#include <string>

namespace capsflow {

struct RunMarker {
  std::string run_id;
  std::string host;
  long pid = 0;
  unsigned long long start_ticks = 0;  // the process's start time (/proc/PID/stat field 22), against pid reuse
  double started = 0.0;                // when the process wrote the marker first (epoch seconds)
  double heartbeat = 0.0;              // its last refresh (epoch seconds)
  double strain = 0.0;                 // strain reached at the last refresh
  double end = 0.0;                    // the strain the run goes to
  std::string slurm_job;               // $SLURM_JOB_ID of the process (empty outside Slurm)
};

// A marker on another host older than this counts as dead. Longer than any step of a production run.
inline constexpr double kStaleSeconds = 900.0;

enum class MarkerOwner {
  Live,  // this host: the process exists; another host: heartbeat younger than kStaleSeconds
  Dead,  // this host: no such process (or the pid was reused); another host: heartbeat older than kStaleSeconds
};

// The marker at `path`, or nullopt when there is none. A marker that cannot be parsed (torn by a crash during its
// first write) reads as a dead marker with empty fields.
std::optional<RunMarker> read_run_marker(const std::filesystem::path& path);
MarkerOwner marker_owner(const RunMarker& m);
// "pid 123 on host h (run id x), last heartbeat 4 s ago at strain 1.2" for messages.
std::string describe_marker(const RunMarker& m);
std::string this_host();
std::string slurm_job_id();  // $SLURM_JOB_ID, or empty
double epoch_seconds();

// Writes and refreshes this process's marker. release() removes it, and so does the destructor (an error, a refusal
// or a full disk ends the process cleanly: its files are complete up to its checkpoint, or removed) and an exit()
// from inside a library (libgomp's "Thread creation failed"), through an atexit handler: only a process that is
// killed or loses its machine leaves the marker, which is what the rerun must recognise.
class RunMarkerFile {
 public:
  RunMarkerFile(std::filesystem::path path, std::string run_id, double strain, double end);
  ~RunMarkerFile();
  RunMarkerFile(const RunMarkerFile&) = delete;
  RunMarkerFile& operator=(const RunMarkerFile&) = delete;
  // Records the strain reached; rewrites the file when a second has passed since the last write (or `force`).
  void beat(double strain, bool force = false);
  void release();

 private:
  void write(bool sync);
  std::filesystem::path path_;
  RunMarker m_;
  bool released_ = false;
};

// An output folder's lock (capsflow render's DIR/render.lock): a marker of the same form, but created with link(2)
// from a complete temporary, so that of two processes taking it at once exactly one gets it and no reader sees a torn
// one. A marker whose process is dead (marker_owner) is stale and taken over. Held until release() or destruction.
class FolderLock {
 public:
  // Takes the lock at `path` for this process, recording `what` as its run_id, unless a live process holds it: then
  // held() is false and holder() is that process's marker. std::system_error naming `path` when it cannot be written
  // (a full disk; the write is counted by the test-only fault injection).
  FolderLock(std::filesystem::path path, const std::string& what);
  ~FolderLock();
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;
  bool held() const { return held_; }
  const RunMarker& holder() const { return holder_; }
  // Refreshes the heartbeat (by which another host judges the lock: kStaleSeconds), at most once every 10 s; a
  // failed refresh is ignored.
  void beat();
  void release();

 private:
  std::filesystem::path path_;
  RunMarker m_;
  RunMarker holder_;
  bool held_ = false;
};

}  // namespace capsflow
