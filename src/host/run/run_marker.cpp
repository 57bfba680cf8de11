// OUT.lock, the marker of a live run, and FolderLock, an output folder's lock of the same form: written as JSON, read
// as JSON or as the older `key = value` text (run_marker.hpp).
#include "host/run/run_marker.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <climits>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <system_error>

#include <nlohmann/json.hpp>

#include "host/base/atomic_file.hpp"
#include "host/base/fault_injection.hpp"

namespace capsflow {

namespace fs = std::filesystem;

namespace {

struct ProcStat {
  char state = '?';                 // field 3: 'Z' for a zombie (dead, not yet reaped)
  unsigned long long start_ticks = 0;  // field 22: start time in clock ticks after boot
};

// /proc/PID/stat; zeros when unknown. The command name (field 2) may hold spaces and parentheses, so the fields
// are counted from the last ')'.
ProcStat proc_stat(long pid) {
  ProcStat st;
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t close = s.rfind(')');
  if (close == std::string::npos) return st;
  std::istringstream rest(s.substr(close + 1));
  std::string field;
  for (int i = 3; i <= 22; ++i) {
    if (!(rest >> field)) return st;
    if (i == 3) st.state = field[0];
  }
  try {
    st.start_ticks = std::stoull(field);
  } catch (...) {
  }
  return st;
}

unsigned long long process_start_ticks(long pid) { return proc_stat(pid).start_ticks; }

bool process_alive(long pid, unsigned long long start_ticks) {
  if (pid <= 0) return false;
  if (::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) return false;
  const ProcStat now = proc_stat(pid);
  if (now.state == 'Z') return false;
  // No /proc (or no start time recorded): the pid's existence is all there is to go on.
  return now.start_ticks == 0 || start_ticks == 0 || now.start_ticks == start_ticks;
}

}  // namespace

std::string slurm_job_id() {
  const char* j = std::getenv("SLURM_JOB_ID");
  return j ? j : "";
}

double epoch_seconds() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::string this_host() {
  char name[HOST_NAME_MAX + 1] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "unknown";
  return name;
}

std::optional<RunMarker> read_run_marker(const fs::path& path) {
  std::ifstream in(path);
  if (!in) return std::nullopt;
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  RunMarker m;
  const std::size_t first = text.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && text[first] == '{') {
    // A torn or foreign file parses to nothing, or a value of the wrong type reads as absent: the marker then counts
    // as dead (pid 0).
    const nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (!j.is_object()) return m;
    const auto str = [&](const char* k, std::string& v) {
      if (j.contains(k) && j[k].is_string()) v = j[k].get<std::string>();
    };
    const auto number = [&](const char* k, double& v) {
      if (j.contains(k) && j[k].is_number()) v = j[k].get<double>();
    };
    str("run_id", m.run_id);
    str("host", m.host);
    str("slurm_job", m.slurm_job);
    if (j.contains("pid") && j["pid"].is_number_integer()) m.pid = j["pid"].get<long>();
    if (j.contains("start_ticks") && j["start_ticks"].is_number_unsigned())
      m.start_ticks = j["start_ticks"].get<unsigned long long>();
    number("started", m.started);
    number("heartbeat", m.heartbeat);
    number("strain", m.strain);
    number("end", m.end);
    return m;
  }
  // The format before 2026-12-07, one `key = value` per line: a marker left by an older build still reads.
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    const std::size_t eq = line.find(" = ");
    if (eq == std::string::npos) continue;
    const std::string key = line.substr(0, eq), value = line.substr(eq + 3);
    try {
      if (key == "run_id") m.run_id = value;
      else if (key == "host") m.host = value;
      else if (key == "pid") m.pid = std::stol(value);
      else if (key == "start_ticks") m.start_ticks = std::stoull(value);
      else if (key == "started") m.started = std::stod(value);
      else if (key == "heartbeat") m.heartbeat = std::stod(value);
      else if (key == "strain") m.strain = std::stod(value);
      else if (key == "end") m.end = std::stod(value);
      else if (key == "slurm_job") m.slurm_job = value;
    } catch (...) {
      // A torn value reads as absent: the marker then counts as dead (pid 0).
    }
  }
  return m;
}

MarkerOwner marker_owner(const RunMarker& m) {
  if (m.host.empty() || m.pid <= 0) return MarkerOwner::Dead;
  if (m.host == this_host()) return process_alive(m.pid, m.start_ticks) ? MarkerOwner::Live : MarkerOwner::Dead;
  if (!m.slurm_job.empty() && m.slurm_job == slurm_job_id()) return MarkerOwner::Dead;
  return epoch_seconds() - m.heartbeat < kStaleSeconds ? MarkerOwner::Live : MarkerOwner::Dead;
}

std::string describe_marker(const RunMarker& m) {
  char b[64];
  std::snprintf(b, sizeof b, "%.0f s ago at strain %.6g", epoch_seconds() - m.heartbeat, m.strain);
  return "pid " + std::to_string(m.pid) + " on host " + (m.host.empty() ? "?" : m.host) + " (run id " +
         (m.run_id.empty() ? "?" : m.run_id) + "), last heartbeat " + b;
}

namespace {
// The marker of this process while it is held, for exit() paths that skip destructors (libgomp's fatal errors call
// exit(1)). One run per process holds a marker at a time.
char g_held_marker[4096] = {0};

extern "C" void capsflow_remove_held_marker() {
  if (g_held_marker[0] != '\0') ::unlink(g_held_marker);
}

void hold_marker(const fs::path& p) {
  static const bool registered = std::atexit(capsflow_remove_held_marker) == 0;
  (void)registered;
  const std::string s = fs::absolute(p).string();
  if (s.size() < sizeof g_held_marker) std::memcpy(g_held_marker, s.c_str(), s.size() + 1);
}

void drop_marker() { g_held_marker[0] = '\0'; }
}  // namespace

RunMarkerFile::~RunMarkerFile() { release(); }

namespace {
// This process's marker, started now (a run's, or a folder lock's), under the id `what`.
RunMarker this_process(const std::string& what) {
  RunMarker m;
  m.run_id = what;
  m.host = this_host();
  m.pid = static_cast<long>(::getpid());
  m.start_ticks = process_start_ticks(m.pid);
  m.started = m.heartbeat = epoch_seconds();
  m.slurm_job = slurm_job_id();
  return m;
}
}  // namespace

RunMarkerFile::RunMarkerFile(fs::path path, std::string run_id, double strain, double end)
    : path_(std::move(path)), m_(this_process(run_id)) {
  m_.strain = strain;
  m_.end = end;
  try {
    write(true);  // on disk before the output it guards
  } catch (...) {
    // The write can fail after its rename (the directory's sync): the marker is then ours, on disk, and no destructor
    // will remove it. A marker of an earlier process that stayed in place is left as it was.
    const std::optional<RunMarker> there = read_run_marker(path_);
    std::error_code ec;
    if (there && there->pid == m_.pid && there->start_ticks == m_.start_ticks) fs::remove(path_, ec);
    throw;
  }
  hold_marker(path_);
}

void RunMarkerFile::beat(double strain, bool force) {
  if (released_) return;
  m_.strain = strain;
  const double now = epoch_seconds();
  if (!force && now - m_.heartbeat < 1.0) return;
  m_.heartbeat = now;
  write(false);
}

void RunMarkerFile::release() {
  if (released_) return;
  released_ = true;
  drop_marker();
  std::error_code ec;
  fs::remove(path_, ec);
}

namespace {

// JSON through nlohmann-json: numbers in the shortest text that reads back to the same double.
std::string marker_text(const RunMarker& m) {
  nlohmann::ordered_json j;
  j["run_id"] = m.run_id;
  j["host"] = m.host;
  j["pid"] = m.pid;
  j["start_ticks"] = m.start_ticks;
  j["started"] = m.started;
  j["heartbeat"] = m.heartbeat;
  j["strain"] = m.strain;
  j["end"] = m.end;
  j["slurm_job"] = m.slurm_job;
  std::ostringstream o;
  o << j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << "\n";
  return o.str();
}

// A heartbeat need not survive a power loss: rename without fsync (a reader still never sees a torn file), and a
// missed one is not worth stopping for.
void rewrite_quietly(const fs::path& path, const std::string& text) {
  const std::string tmp = temp_path_for(path);
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    f << text;
    if (!f) {
      std::error_code ec;
      fs::remove(tmp, ec);
      return;
    }
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) fs::remove(tmp, ec);
}

bool same_process(const RunMarker& a, const RunMarker& b) {
  return a.host == b.host && a.pid == b.pid && a.start_ticks == b.start_ticks && a.started == b.started;
}

[[noreturn]] void throw_lock_error(int err, const fs::path& path) {
  throw std::system_error(err, std::generic_category(), "cannot write '" + path.string() + "'");
}

// `text` into the new file `tmp` (O_EXCL), closed; the write counted by the test-only fault injection.
void write_new_file(const std::string& tmp, const std::string& text, const fs::path& target) {
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) throw_lock_error(errno, target);
  std::size_t done = 0;
  int err = fault_point("write", tmp);
  while (!err && done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n > 0) done += static_cast<std::size_t>(n);
    else if (n < 0 && errno != EINTR) err = errno;
  }
  if (::close(fd) != 0 && !err) err = errno;
  if (err) {
    ::unlink(tmp.c_str());
    throw_lock_error(err, target);
  }
}

}  // namespace

void RunMarkerFile::write(bool sync) {
  const std::string text = marker_text(m_);
  if (sync) write_file_atomically(path_, text);
  else rewrite_quietly(path_, text);
}

FolderLock::FolderLock(fs::path path, const std::string& what) : path_(std::move(path)), m_(this_process(what)) {
  const std::string text = marker_text(m_);
  // A few rounds: each ends with the lock ours, refused by a live holder, or a stale one cleared away.
  for (int round = 0; round < 8; ++round) {
    const std::string tmp = temp_path_for(path_);
    write_new_file(tmp, text, path_);
    const int rc = ::link(tmp.c_str(), path_.c_str());
    const int err = errno;
    ::unlink(tmp.c_str());
    if (rc == 0) {
      held_ = true;
      return;
    }
    if (err != EEXIST) throw_lock_error(err, path_);
    const std::optional<RunMarker> there = read_run_marker(path_);
    if (!there) continue;  // removed in between: again
    if (marker_owner(*there) == MarkerOwner::Live) {
      holder_ = *there;
      return;
    }
    // Stale. Moved aside under a name of our own, then removed if it is the dead marker just read: another process
    // may have cleared it and taken the lock in between, and its live marker, moved aside by us, goes back.
    const std::string aside = temp_path_for(path_);
    if (::rename(path_.c_str(), aside.c_str()) != 0) continue;
    const std::optional<RunMarker> moved = read_run_marker(aside);
    if (!(moved && same_process(*moved, *there))) ::link(aside.c_str(), path_.c_str());  // fails if taken again
    ::unlink(aside.c_str());
  }
  const std::optional<RunMarker> there = read_run_marker(path_);
  if (there && marker_owner(*there) == MarkerOwner::Live) {
    holder_ = *there;
    return;
  }
  throw_lock_error(EBUSY, path_);  // contended by one process after another, each dying: not worth a longer fight
}

FolderLock::~FolderLock() { release(); }

void FolderLock::beat() {
  if (!held_) return;
  const double now = epoch_seconds();
  if (now - m_.heartbeat < 10.0) return;
  m_.heartbeat = now;
  rewrite_quietly(path_, marker_text(m_));
}

void FolderLock::release() {
  if (!held_) return;
  held_ = false;
  // Only our own marker: a lock cleared as stale and taken by another process (ours cannot be stale while we live,
  // but a clock or /proc oddity could make it look so) is left to it.
  const std::optional<RunMarker> there = read_run_marker(path_);
  std::error_code ec;
  if (there && same_process(*there, m_)) fs::remove(path_, ec);
}

}  // namespace capsflow
