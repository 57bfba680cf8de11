// The implementation of atomic_file.hpp: safe creation and replacement of output files.
#include "host/base/atomic_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <fstream>
#include <system_error>

#include "host/base/errors.hpp"
#include "host/base/fault_injection.hpp"

namespace capsflow {

namespace fs = std::filesystem;

namespace {

fs::path directory_of(const fs::path& path) {
  fs::path dir = path.parent_path();
  return dir.empty() ? fs::path(".") : dir;
}

[[noreturn]] void throw_errno(int err, const std::string& what) {
  throw std::system_error(err, std::generic_category(), what);
}

}  // namespace

void check_output_kind(const fs::path& path) {
  std::error_code ec;
  const fs::file_status ls = fs::symlink_status(path, ec);
  if (fs::is_symlink(ls))
    throw InputError("output file '" + path.string() + "' is a symbolic link: an output is written as a regular "
                     "file (name the file it points to, or remove the link)");
  if (fs::exists(ls) && !fs::is_regular_file(ls) && !fs::is_directory(ls))
    throw InputError("output file '" + path.string() + "' exists and is not a regular file (a device, FIFO or "
                     "socket): an output is written as a regular file");
}

void check_not_an_input(const fs::path& path, const std::vector<std::pair<fs::path, std::string>>& inputs) {
  for (const auto& [input, what] : inputs) {
    std::error_code ec;
    if (!input.empty() && fs::equivalent(path, input, ec))
      throw InputError("output file '" + path.string() + "' is this run's " + what + " '" + input.string() +
                       "': choose another output name (--force never replaces an input)");
  }
}

void ensure_can_create(const fs::path& path, bool overwrite) {
  const std::string name = "'" + path.string() + "'";
  if (path.empty() || path.filename().empty())
    throw InputError("output file " + name + ": not a file name");
  check_output_kind(path);
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (fs::exists(st)) {
    if (fs::is_directory(st)) throw InputError("output file " + name + " is an existing directory");
    if (!overwrite)
      throw InputError("output file " + name +
                       " already exists; refusing to overwrite it (remove it, choose another output "
                       "directory, or allow overwriting)");
  }
  const fs::path dir = directory_of(path);
  if (!fs::is_directory(dir, ec))
    throw InputError("cannot create output file " + name + ": directory '" + dir.string() + "' does not exist");
  if (::access(dir.c_str(), W_OK | X_OK) != 0)
    throw InputError("cannot create output file " + name + ": directory '" + dir.string() + "' is not writable");
  if (fs::exists(st) && ::access(path.c_str(), W_OK) != 0)
    throw InputError("cannot overwrite output file " + name + ": it is not writable");
}

std::string temp_path_for(const fs::path& path) {
  static std::atomic<unsigned long> counter{0};
  const unsigned long n = counter.fetch_add(1);
  const fs::path name = "." + path.filename().string() + ".tmp." + std::to_string(::getpid()) + "." +
                        std::to_string(n);
  return (path.parent_path() / name).string();
}

void remove_stale_temporaries(const fs::path& path) {
  const std::string prefix = "." + path.filename().string() + ".tmp.";
  std::error_code ec;
  fs::directory_iterator it(directory_of(path), ec), end;
  for (; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.rfind(prefix, 0) != 0) continue;
    // ".<name>.tmp.<pid>.<n>": the writer's pid, then a counter.
    const std::string rest = name.substr(prefix.size());
    const std::size_t dot = rest.find('.');
    if (dot == 0 || dot == std::string::npos || rest.find_first_not_of("0123456789.") != std::string::npos) continue;
    const long pid = std::stol(rest.substr(0, dot));
    const bool alive = pid == static_cast<long>(::getpid()) || ::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM;
    std::error_code kind;
    if (!alive && fs::is_regular_file(fs::symlink_status(it->path(), kind))) {
      std::error_code ignored;
      fs::remove(it->path(), ignored);
    }
  }
}

void fsync_path(const fs::path& path) {
  if (const int err = fault_point("fsync", path.string())) throw_errno(err, "cannot sync '" + path.string() + "'");
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw_errno(errno, "cannot open '" + path.string() + "' to sync it");
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    // Some file systems (and directories on some of them) do not support fsync; that is not a failure of
    // the write itself.
    if (err == EINVAL || err == ENOTSUP) return;
    throw_errno(err, "cannot sync '" + path.string() + "'");
  }
  ::close(fd);
}

void replace_file_atomically(const fs::path& path, const std::function<void(const fs::path& tmp)>& produce) {
  const fs::path tmp = temp_path_for(path);
  try {
    produce(tmp);
    fsync_path(tmp);
    std::error_code ec;
    if (const int err = fault_point("rename", path.string())) ec = std::error_code(err, std::generic_category());
    else fs::rename(tmp, path, ec);
    if (ec) throw std::system_error(ec, "cannot rename '" + tmp.string() + "' to '" + path.string() + "'");
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw;
  }
  fsync_path(directory_of(path));
}

void write_file_atomically(const fs::path& path, const std::function<void(std::ostream&)>& writer) {
  replace_file_atomically(path, [&](const fs::path& tmp) {
    std::ofstream os(tmp, std::ios::binary | std::ios::trunc);
    if (!os) throw_errno(errno, "cannot create '" + tmp.string() + "'");
    errno = 0;
    writer(os);
    os.flush();
    // The stream keeps no reason; errno still holds the failed write's (ENOSPC on a full disk).
    if (!os) throw_errno(errno ? errno : EIO, "cannot write '" + path.string() + "'");
    if (const int err = fault_point("write", tmp.string())) throw_errno(err, "cannot write '" + path.string() + "'");
    os.close();
    if (os.fail()) throw_errno(errno ? errno : EIO, "cannot close '" + path.string() + "'");
  });
}

void write_file_atomically(const fs::path& path, std::string_view content) {
  write_file_atomically(path, [&](std::ostream& os) { os.write(content.data(), static_cast<std::streamsize>(content.size())); });
}

}  // namespace capsflow
