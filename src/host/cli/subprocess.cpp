// The implementation of subprocess.hpp: running helper programs without a shell and waiting for them.
#include "host/cli/subprocess.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <system_error>
#include <thread>

#include "host/base/stopwatch.hpp"

extern char** environ;

namespace capsflow {
namespace {

int decode_status(int raw) {
  if (WIFEXITED(raw)) return WEXITSTATUS(raw);
  if (WIFSIGNALED(raw)) return 128 + WTERMSIG(raw);
  return 1;
}

bool is_executable_file(const std::string& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::access(p.c_str(), X_OK) == 0;
}

// --- own_group: the child's process group ends with us ---------------------------------------------------------------

constexpr std::array<int, 4> kForwarded = {SIGINT, SIGTERM, SIGHUP, SIGQUIT};

// What the handler needs: the group to end (0: none yet) and the first signal received.
volatile sig_atomic_t g_group = 0;
volatile sig_atomic_t g_signal = 0;

extern "C" void capsflow_end_child_group(int sig) {
  const int saved = errno;
  if (g_signal == 0) g_signal = sig;
  const pid_t group = static_cast<pid_t>(g_group);
  if (group > 0) ::kill(-group, SIGTERM);
  errno = saved;
}

// A descriptor numbered 3 or above (close-on-exec): one of 0..2 (a caller started with stdin closed) would be
// overwritten by the child's dup2 onto its standard streams.
int above_std_streams(int fd) {
  if (fd < 0 || fd > 2) return fd;
  const int moved = ::fcntl(fd, F_DUPFD_CLOEXEC, 3);
  ::close(fd);
  return moved;
}

void close_fd(int& fd) {
  if (fd >= 0) ::close(fd);
  fd = -1;
}

// Whether a live process other than `a` and `b` is in process group `group` (/proc; false without it).
bool group_has_others(pid_t group, pid_t a, pid_t b) {
  DIR* d = ::opendir("/proc");
  if (!d) return false;
  bool found = false;
  while (const dirent* e = ::readdir(d)) {
    char* end = nullptr;
    const long pid = std::strtol(e->d_name, &end, 10);
    if (pid <= 0 || *end != '\0' || pid == a || pid == b) continue;
    std::ifstream in(std::string("/proc/") + e->d_name + "/stat");
    const std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::size_t close = s.rfind(')');
    if (close == std::string::npos) continue;
    char state = '?';
    long ppid = 0, pgrp = 0;
    if (std::sscanf(s.c_str() + close + 1, " %c %ld %ld", &state, &ppid, &pgrp) != 3) continue;
    if (pgrp == group && state != 'Z') {
      found = true;
      break;
    }
  }
  ::closedir(d);
  return found;
}

// The child's stdout, as it comes, to the options' collector and line handler.
struct OutputReader {
  const ProcessOptions& options;
  std::string* out;
  std::string pending;
  void take(const char* buf, std::size_t n) {
    if (options.capture_stdout) out->append(buf, n);
    if (!options.on_line) return;
    pending.append(buf, n);
    for (std::size_t nl = pending.find('\n'); nl != std::string::npos; nl = pending.find('\n')) {
      options.on_line(pending.substr(0, nl));
      pending.erase(0, nl + 1);
    }
  }
  void finish() {
    if (options.on_line && !pending.empty()) options.on_line(pending);
    pending.clear();
  }
};

// The own_group path: fork and exec by hand (posix_spawn can neither set PR_SET_PDEATHSIG nor start the watchdog).
ProcessResult run_in_own_group(const std::vector<std::string>& argv, const ProcessOptions& options) {
  ProcessResult r;
  // Everything the child needs is prepared here: between fork and exec only async-signal-safe calls (this process
  // may have threads: OpenMP's, HDF5's).
  const std::string program = argv[0].find('/') != std::string::npos ? argv[0] : find_program(argv[0]);
  if (program.empty()) {
    r.error = ENOENT;
    return r;
  }
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const bool read_out = options.capture_stdout || static_cast<bool>(options.on_line);

  int out_pipe[2] = {-1, -1}, exec_pipe[2] = {-1, -1}, life_pipe[2] = {-1, -1};
  int null_fd = -1, err_fd = -1;
  auto close_all = [&] {
    for (int* fd : {&out_pipe[0], &out_pipe[1], &exec_pipe[0], &exec_pipe[1], &life_pipe[0], &life_pipe[1], &null_fd,
                    &err_fd})
      close_fd(*fd);
  };
  auto make_pipe = [&](int (&p)[2]) {
    if (::pipe2(p, O_CLOEXEC) != 0) {
      const int err = errno;
      close_all();
      throw std::system_error(err, std::generic_category(), "pipe2");
    }
    p[0] = above_std_streams(p[0]);
    p[1] = above_std_streams(p[1]);
  };
  if (read_out) make_pipe(out_pipe);
  make_pipe(exec_pipe);  // the child's exec errno, or end-of-file when exec succeeded
  make_pipe(life_pipe);  // the watchdog's: end-of-file when this process is gone
  null_fd = above_std_streams(::open("/dev/null", O_RDWR | O_CLOEXEC));
  if (!options.stderr_file.empty() && !options.discard_stderr) {
    err_fd = above_std_streams(::open(options.stderr_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
    if (err_fd < 0) {
      r.error = errno;
      close_all();
      return r;
    }
  }
  if (null_fd < 0) {
    r.error = errno;
    close_all();
    return r;
  }

  // The handlers go in before the fork, with the signals blocked until the group is known: a signal in between is
  // delivered (and forwarded) then, not lost and not fatal to us alone.
  sigset_t forwarded, old_mask;
  sigemptyset(&forwarded);
  for (int s : kForwarded) sigaddset(&forwarded, s);
  ::pthread_sigmask(SIG_BLOCK, &forwarded, &old_mask);
  struct sigaction sa {}, old_actions[kForwarded.size()];
  sa.sa_handler = capsflow_end_child_group;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;  // no SA_RESTART: poll and nanosleep return at once
  g_group = 0;
  g_signal = 0;
  for (std::size_t k = 0; k < kForwarded.size(); ++k) ::sigaction(kForwarded[k], &sa, &old_actions[k]);
  auto restore_signals = [&] {
    g_group = 0;
    for (std::size_t k = 0; k < kForwarded.size(); ++k) ::sigaction(kForwarded[k], &old_actions[k], nullptr);
    ::pthread_sigmask(SIG_SETMASK, &old_mask, nullptr);
  };
  struct sigaction dfl {};
  dfl.sa_handler = SIG_DFL;
  sigemptyset(&dfl.sa_mask);

  std::fflush(nullptr);  // our buffered output must come before the child's
  std::cout.flush();
  std::cerr.flush();
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    r.error = errno;
    restore_signals();
    close_all();
    return r;
  }
  if (pid == 0) {
    // The child: its own group; SIGTERM when we die (and already dead: end now); default signal actions, unblocked.
    ::setpgid(0, 0);
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != parent) ::_exit(127);
    for (int s : kForwarded) ::sigaction(s, &dfl, nullptr);
    ::sigprocmask(SIG_SETMASK, &old_mask, nullptr);
    int ok = ::dup2(null_fd, STDIN_FILENO) >= 0;
    if (read_out) ok = ok && ::dup2(out_pipe[1], STDOUT_FILENO) >= 0;
    if (options.discard_stderr) ok = ok && ::dup2(null_fd, STDERR_FILENO) >= 0;
    else if (err_fd >= 0) ok = ok && ::dup2(err_fd, STDERR_FILENO) >= 0;
    if (ok) ::execve(program.c_str(), args.data(), environ);
    const int err = errno;
    [[maybe_unused]] const ssize_t w = ::write(exec_pipe[1], &err, sizeof err);
    ::_exit(127);
  }
  ::setpgid(pid, pid);  // also here: the group exists before the watchdog joins it, whichever runs first
  g_group = pid;
  close_fd(exec_pipe[1]);
  close_fd(out_pipe[1]);
  close_fd(err_fd);

  // The watchdog: a fork of this process in the child's group that never execs. It holds only the lifeline's read
  // end; end-of-file there means we are gone (killed outright, with no handler run): it ends the group, SIGTERM, then
  // SIGKILL after the grace (itself too). It ignores SIGTERM so as to live to send the SIGKILL.
  const pid_t watchdog = ::fork();
  if (watchdog == 0) {
    ::setpgid(0, pid);
    struct sigaction ign {};
    ign.sa_handler = SIG_IGN;
    sigemptyset(&ign.sa_mask);
    ::sigaction(SIGTERM, &ign, nullptr);
    for (int s : {SIGINT, SIGHUP, SIGQUIT}) ::sigaction(s, &dfl, nullptr);
    ::sigprocmask(SIG_SETMASK, &old_mask, nullptr);
    // Not our standard streams (a reader of our stderr must see its end when we end), and no other descriptor of
    // ours: the lifeline's write end above all, or its end-of-file would never come.
    ::dup2(null_fd, STDIN_FILENO);
    ::dup2(null_fd, STDOUT_FILENO);
    ::dup2(null_fd, STDERR_FILENO);
    const int life = 3;
    if (::dup2(life_pipe[0], life) != life) ::_exit(1);
    if (::close_range(life + 1, ~0U, 0) != 0)
      for (int fd = life + 1; fd < 65536; ++fd) ::close(fd);  // a kernel before 5.9
    char c;
    while (::read(life, &c, 1) != 0) {
      if (errno != EINTR) break;
    }
    ::kill(-pid, SIGTERM);
    struct timespec grace {};
    grace.tv_sec = static_cast<time_t>(kGroupGraceSeconds);
    while (::nanosleep(&grace, &grace) != 0 && errno == EINTR) {
    }
    ::kill(-pid, SIGKILL);
    ::_exit(0);
  }
  if (watchdog > 0) ::setpgid(watchdog, pid);
  close_fd(life_pipe[0]);
  close_fd(null_fd);
  ::pthread_sigmask(SIG_SETMASK, &old_mask, nullptr);  // a signal that came meanwhile is forwarded now

  // Did exec succeed? (end-of-file: the descriptor closed on exec; an errno: it failed)
  int exec_error = 0;
  for (;;) {
    const ssize_t n = ::read(exec_pipe[0], &exec_error, sizeof exec_error);
    if (n >= 0 || errno != EINTR) break;
  }
  close_fd(exec_pipe[0]);

  // Wait: the child's stdout as it comes, our signals, the grace after the SIGTERM. The child's exit is seen without
  // reaping it (WNOWAIT): until it is reaped its process id stays its group's, so the group cannot be confused with a
  // newcomer's.
  OutputReader reader{options, &r.out, {}};
  std::chrono::steady_clock::time_point term_sent{};
  bool terminating = false, killed = false;
  auto leader_exited = [&] {
    siginfo_t info{};
    return ::waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == pid;
  };
  char buf[4096];
  for (;;) {
    if (g_signal != 0 && !terminating) {
      // Sent by the handler too, unless another thread took the signal before the group was known.
      ::kill(-pid, SIGTERM);
      terminating = true;
      term_sent = std::chrono::steady_clock::now();
    }
    if (terminating && !killed && seconds_since(term_sent) > kGroupGraceSeconds) {
      ::kill(-pid, SIGKILL);
      killed = true;
    }
    if (leader_exited()) break;
    struct pollfd p {out_pipe[0], POLLIN, 0};
    const int ready = ::poll(&p, out_pipe[0] >= 0 ? 1 : 0, 100);
    if (ready > 0) {
      const ssize_t n = ::read(out_pipe[0], buf, sizeof buf);
      if (n > 0) reader.take(buf, static_cast<std::size_t>(n));
      else if (n == 0 || errno != EINTR) close_fd(out_pipe[0]);
    }
  }
  // What the child wrote before it ended is in the pipe; a descendant that still holds the pipe does not keep us.
  if (out_pipe[0] >= 0) {
    ::fcntl(out_pipe[0], F_SETFL, O_NONBLOCK);
    for (ssize_t n; (n = ::read(out_pipe[0], buf, sizeof buf)) > 0;) reader.take(buf, static_cast<std::size_t>(n));
    close_fd(out_pipe[0]);
  }
  reader.finish();
  // What the child left running in its group (an X server, a helper) ends too: SIGTERM, SIGKILL after the grace.
  if (group_has_others(pid, pid, watchdog)) {
    if (!terminating) {
      ::kill(-pid, SIGTERM);
      terminating = true;
      term_sent = std::chrono::steady_clock::now();
    }
    while (group_has_others(pid, pid, watchdog) && seconds_since(term_sent) < kGroupGraceSeconds)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (group_has_others(pid, pid, watchdog)) ::kill(-pid, SIGKILL);
  }
  if (watchdog > 0) {
    ::kill(watchdog, SIGKILL);
    while (::waitpid(watchdog, nullptr, 0) < 0 && errno == EINTR) {
    }
  }
  close_fd(life_pipe[1]);
  g_group = 0;  // before the reap: once reaped, the child's id may pass to another process's group
  int raw = 0;
  while (::waitpid(pid, &raw, 0) < 0) {
    if (errno != EINTR) {
      const int err = errno;
      restore_signals();
      throw std::system_error(err, std::generic_category(), "waitpid");
    }
  }
  r.signal = static_cast<int>(g_signal);
  restore_signals();
  if (exec_error != 0) {
    r.error = exec_error;
    return r;
  }
  r.started = true;
  r.status = decode_status(raw);
  return r;
}

}  // namespace

ProcessResult run_process(const std::vector<std::string>& argv, const ProcessOptions& options) {
  if (options.own_group) return run_in_own_group(argv, options);
  std::vector<char*> args;
  args.reserve(argv.size() + 1);
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);

  const bool read_out = options.capture_stdout || static_cast<bool>(options.on_line);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  int pipe_fd[2] = {-1, -1};
  if (read_out) {
    if (::pipe2(pipe_fd, O_CLOEXEC) != 0) {
      posix_spawn_file_actions_destroy(&actions);
      throw std::system_error(errno, std::generic_category(), "pipe2");
    }
    posix_spawn_file_actions_adddup2(&actions, pipe_fd[1], STDOUT_FILENO);
  }
  if (options.discard_stderr)
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  else if (!options.stderr_file.empty())
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, options.stderr_file.c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::fflush(nullptr);  // our buffered output must come before the child's
  std::cout.flush();
  std::cerr.flush();
  pid_t pid = -1;
  const int rc = ::posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ProcessResult r;
  if (read_out) ::close(pipe_fd[1]);
  if (rc != 0) {
    if (read_out) ::close(pipe_fd[0]);
    r.error = rc;
    return r;
  }
  r.started = true;
  if (read_out) {
    OutputReader reader{options, &r.out, {}};
    char buf[4096];
    for (;;) {
      const ssize_t n = ::read(pipe_fd[0], buf, sizeof buf);
      if (n > 0) reader.take(buf, static_cast<std::size_t>(n));
      else if (n == 0 || errno != EINTR) break;
    }
    reader.finish();
    ::close(pipe_fd[0]);
  }
  int raw = 0;
  while (::waitpid(pid, &raw, 0) < 0) {
    if (errno != EINTR) throw std::system_error(errno, std::generic_category(), "waitpid");
  }
  r.status = decode_status(raw);
  return r;
}

std::string find_program(const std::string& name) {
  if (name.empty()) return {};
  if (name.find('/') != std::string::npos) return is_executable_file(name) ? name : std::string();
  const char* path = std::getenv("PATH");
  const std::string dirs = path ? path : "/usr/local/bin:/usr/bin:/bin";
  std::size_t start = 0;
  for (;;) {
    const std::size_t colon = dirs.find(':', start);
    std::string dir = dirs.substr(start, colon == std::string::npos ? std::string::npos : colon - start);
    if (dir.empty()) dir = ".";
    const std::string candidate = dir + "/" + name;
    if (is_executable_file(candidate)) return candidate;
    if (colon == std::string::npos) return {};
    start = colon + 1;
  }
}

}  // namespace capsflow
