#pragma once
// Test helper: a small tmpfs for disk-full cases, mounted where this machine lets the test mount one (root with
// CAP_SYS_ADMIN; otherwise `mounted` is false and `why` says why, for GTEST_SKIP); unmounted at the end.
#include <gtest/gtest.h>
#include <sys/mount.h>
#include <sys/statvfs.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

namespace capsflow::test {

struct SmallTmpfs {
  std::filesystem::path dir;
  bool mounted = false;
  std::string why;
  SmallTmpfs(const std::filesystem::path& d, const std::string& size) : dir(d) {
    std::filesystem::create_directories(dir);
    if (::mount("tmpfs", dir.c_str(), "tmpfs", 0, ("size=" + size).c_str()) == 0)
      mounted = true;
    else
      why = std::string("cannot mount a tmpfs here: ") + std::strerror(errno);
  }
  ~SmallTmpfs() {
    if (mounted) ::umount2(dir.c_str(), MNT_DETACH);
  }
  SmallTmpfs(const SmallTmpfs&) = delete;
  SmallTmpfs& operator=(const SmallTmpfs&) = delete;
  // Room made after a failure: the same mount, larger.
  bool grow(const std::string& size) {
    return ::mount("tmpfs", dir.c_str(), "tmpfs", MS_REMOUNT, ("size=" + size).c_str()) == 0;
  }
  // Fills the file system with `filler` until `free_bytes` (whole pages) are left.
  void leave_free(std::size_t free_bytes) const {
    std::error_code ec;
    std::filesystem::remove(dir / "filler", ec);
    struct statvfs st {};
    ASSERT_EQ(::statvfs(dir.c_str(), &st), 0);
    const std::size_t avail = static_cast<std::size_t>(st.f_bavail) * st.f_frsize;
    ASSERT_GE(avail, free_bytes);
    std::ofstream(dir / "filler", std::ios::binary) << std::string(avail - free_bytes, 'x');
  }
};

}  // namespace capsflow::test
