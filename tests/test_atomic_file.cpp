// Safe output files: refusing to clobber, atomic replacement, cleanup of temporaries.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <stdexcept>
#include <string>

#include "host/base/atomic_file.hpp"
#include "host/base/errors.hpp"
#include "support/temp_dir.hpp"

namespace capsflow::test {
namespace {

namespace fs = std::filesystem;



void put(const fs::path& p, const std::string& s) {
  std::ofstream os(p, std::ios::binary);
  os << s;
}

TEST(AtomicFile, TempPathIsHiddenInSameDirectoryAndUnique) {
  const fs::path target = fs::path("/some/dir") / "run.h5";
  const std::string a = temp_path_for(target), b = temp_path_for(target);
  EXPECT_NE(a, b);
  EXPECT_EQ(fs::path(a).parent_path(), target.parent_path());
  EXPECT_EQ(fs::path(a).filename().string().rfind(".run.h5.tmp.", 0), 0u) << a;
  EXPECT_EQ(fs::path(temp_path_for("run.h5")).parent_path(), fs::path());  // relative stays relative
}

TEST(AtomicFile, EnsureCanCreateRefusesExistingFileUnlessOverwrite) {
  TempDir dir;
  const fs::path f = dir.path / "run.h5";
  EXPECT_NO_THROW(ensure_can_create(f, false));
  EXPECT_FALSE(fs::exists(f)) << "the check must not create the file";
  put(f, "old");
  try {
    ensure_can_create(f, false);
    FAIL() << "an existing file was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(f.string()), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(ensure_can_create(f, true));
  EXPECT_EQ(slurp(f), "old");
  EXPECT_THROW(ensure_can_create(dir.path, true), InputError);  // a directory is never an output file
}

TEST(AtomicFile, EnsureCanCreateRejectsMissingDirectory) {
  TempDir dir;
  try {
    ensure_can_create(dir.path / "missing" / "run.h5", true);
    FAIL() << "a missing directory was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("run.h5"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
}

TEST(AtomicFile, EnsureCanCreateRejectsReadOnlyDirectory) {
  if (::geteuid() == 0) GTEST_SKIP() << "root ignores directory permissions";
  TempDir dir;
  const fs::path ro = dir.path / "ro";
  fs::create_directory(ro);
  fs::permissions(ro, fs::perms::owner_read | fs::perms::owner_exec);
  EXPECT_THROW(ensure_can_create(ro / "run.h5", true), InputError);
  fs::permissions(ro, fs::perms::owner_all);
}

TEST(AtomicFile, WritesNewFileAndReplacesOldOne) {
  TempDir dir;
  const fs::path f = dir.path / "index.xdmf";
  write_file_atomically(f, std::string_view("first"));
  EXPECT_EQ(slurp(f), "first");
  write_file_atomically(f, [](std::ostream& os) { os << "second " << 2; });
  EXPECT_EQ(slurp(f), "second 2");
  write_file_atomically(f, std::string_view(""));
  EXPECT_EQ(slurp(f), "");
  EXPECT_EQ(dir.entries(), std::set<std::string>{"index.xdmf"});
}

TEST(AtomicFile, ThrowingWriterLeavesOldFileAndNoTemporary) {
  TempDir dir;
  const fs::path f = dir.path / "summary.csv";
  put(f, "old content\n");
  EXPECT_THROW(write_file_atomically(f,
                                     [](std::ostream& os) {
                                       os << "half of the new content";
                                       throw std::runtime_error("writer failed");
                                     }),
               std::runtime_error);
  EXPECT_EQ(slurp(f), "old content\n");
  EXPECT_EQ(dir.entries(), std::set<std::string>{"summary.csv"});
}

TEST(AtomicFile, FailedStreamIsAnError) {
  TempDir dir;
  const fs::path f = dir.path / "out.txt";
  put(f, "old");
  EXPECT_THROW(write_file_atomically(f, [](std::ostream& os) { os.setstate(std::ios::badbit); }), std::runtime_error);
  EXPECT_EQ(slurp(f), "old");
  EXPECT_EQ(dir.entries(), std::set<std::string>{"out.txt"});
}

TEST(AtomicFile, ReplaceFileAtomicallyHandsOverATemporaryInTheSameDirectory) {
  TempDir dir;
  const fs::path f = dir.path / "data.bin";
  fs::path seen;
  replace_file_atomically(f, [&](const fs::path& tmp) {
    seen = tmp;
    EXPECT_FALSE(fs::exists(tmp));
    put(tmp, "payload");
  });
  EXPECT_EQ(seen.parent_path(), f.parent_path());
  EXPECT_FALSE(fs::exists(seen));
  EXPECT_EQ(slurp(f), "payload");
  // A producer that creates nothing: the rename fails, the old file stays.
  EXPECT_THROW(replace_file_atomically(f, [](const fs::path&) {}), std::system_error);
  EXPECT_EQ(slurp(f), "payload");
}

TEST(AtomicFile, MissingDirectoryIsReported) {
  TempDir dir;
  EXPECT_THROW(write_file_atomically(dir.path / "nope" / "x.txt", std::string_view("x")), std::exception);
  EXPECT_TRUE(dir.entries().empty());
}

}  // namespace
}  // namespace capsflow::test
