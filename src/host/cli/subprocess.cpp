// The implementation of subprocess.hpp: running helper programs without a shell and waiting for them.
#include "host/cli/subprocess.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <system_error>

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

}  // namespace

ProcessResult run_process(const std::vector<std::string>& argv, const ProcessOptions& options) {
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
    char buf[4096];
    std::string pending;
    for (;;) {
      const ssize_t n = ::read(pipe_fd[0], buf, sizeof buf);
      if (n > 0) {
        if (options.capture_stdout) r.out.append(buf, static_cast<std::size_t>(n));
        if (options.on_line) {
          pending.append(buf, static_cast<std::size_t>(n));
          for (std::size_t nl = pending.find('\n'); nl != std::string::npos; nl = pending.find('\n')) {
            options.on_line(pending.substr(0, nl));
            pending.erase(0, nl + 1);
          }
        }
      } else if (n == 0 || errno != EINTR) {
        break;
      }
    }
    if (options.on_line && !pending.empty()) options.on_line(pending);
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
