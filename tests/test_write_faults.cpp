// Every write path under an injected I/O error (issue 55), the way SQLite tests itself: each scenario is run once to
// count its counted calls (writes, flushes and truncations of the HDF5 files; writes, fsyncs and renames of the
// atomic-file helpers: src/host/base/fault_injection.hpp), then once per call N with the N-th call and every later one
// failing (ENOSPC for even N, EIO for odd N). For every N: exit 1 with one line `capsflow: error: ...` naming a file
// and the system's reason (the end-of-run compression too: its line says so, and the plain output it leaves holds every
// record); no temporary and no OUT.lock left; every file the command had not changed before the fault bit for bit as
// before; and, the fault lifted, the rerun ends with the same results as the run that met no fault, its series
// compressed as that run's are. Also the reproducer, on a real nearly full disk (a small tmpfs) where this
// machine lets the test mount one. (The Python tools' writers: tests/python/test_python_write_faults.py.)
//
// Which N: all of them with CAPSFLOW_TEST_FAULT_STRIDE=1 (`ctest --preset faults`, the full sweep: about 1500 runs
// of a quarter second each). The default suite fails every second call of the atomic-file helpers and of the HDF5
// flushes and truncations, but only every kWriteStride-th HDF5 write (they are most of the calls: one per piece of
// metadata a flush writes), and reruns every second fault; under AddressSanitizer a sparser sample again, rerunning
// every third, to stay within CI's budget.
#include <gtest/gtest.h>
#include <sys/statvfs.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "host/base/h5_file.hpp"
#include "host/run/checkpoint.hpp"
#include "support/cli_runner.hpp"
#include "support/small_tmpfs.hpp"
#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using namespace capsflow;
using capsflow::test::CliResult;
using capsflow::test::run_capsflow;
using capsflow::test::shell_quote;
using capsflow::test::slurp_file;
using capsflow::test::SmallTmpfs;
using capsflow::test::snapshot_files;
using capsflow::test::TempDir;

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kAddressSanitizer = true;
#else
constexpr bool kAddressSanitizer = false;
#endif
#else
constexpr bool kAddressSanitizer = false;
#endif
// The default suite's sample (see the top): every kWriteStride-th HDF5 write and every kOtherStride-th other call
// failed, every kRerunStride-th fault rerun.
constexpr long long kWriteStride = kAddressSanitizer ? 150 : 40;
constexpr long long kOtherStride = kAddressSanitizer ? 8 : 2;
constexpr long long kRerunStride = kAddressSanitizer ? 3 : 2;

// CAPSFLOW_TEST_FAULT_STRIDE=1: the full sweep (every call failed, every fault rerun).
bool full_sweep() {
  const char* v = std::getenv("CAPSFLOW_TEST_FAULT_STRIDE");
  return v && std::string(v) == "1";
}

void write_text(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
}

// The run: one level-1 capsule, serial, to strain 0.5, records every 0.1, frames and checkpoints every 0.25;
// `ggem` is extra [ggem] keys (a coarse grid makes the sweep's runs a quarter second each).
std::string tiny_config(const std::string& file, const std::string& ggem = "alpha = 2.0\nalpha_hm = 0.5\n") {
  return "[domain]\nH = 6.0\nLx = 8.0\nLz = 8.0\n[ggem]\n" + ggem +
         "[run]\nbackend = \"serial\"\n[capsules]\nmesh_level = 1\n"
         "[[species]]\nname = \"stiff\"\nca = 0.2\n[[capsule]]\nspecies = \"stiff\"\ncenter = [4.0, 3.0, 4.0]\n"
         "[time]\nend = 0.5\n[output]\nfile = \"" + file + "\"\nevery = 0.1\nframes_every = 0.25\n"
         "checkpoint_every = 0.25\n";
}

// Every dataset of an HDF5 file as bytes (numbers as doubles, strings as text), attributes left out (they hold the
// run id, which a fresh start draws anew): two files with equal maps hold the same results.
std::map<std::string, std::string> h5_content(const fs::path& p) {
  std::map<std::string, std::string> m;
  const H5File f = H5File::open(p);
  for (const std::string& d : f.datasets("/")) {
    try {
      const H5Array<double> a = f.read<double>(d);
      std::string bytes(reinterpret_cast<const char*>(a.data.data()), a.data.size() * sizeof(double));
      for (std::size_t n : a.dims) bytes += "|" + std::to_string(n);
      m[d] = bytes;
    } catch (const H5Error&) {
      m[d] = "string:" + f.read_string(d);
    }
  }
  return m;
}

std::string first_difference(const std::map<std::string, std::string>& a,
                             const std::map<std::string, std::string>& b) {
  for (const auto& [k, v] : a) {
    const auto it = b.find(k);
    if (it == b.end()) return k + " missing";
    if (it->second != v) return k + " differs";
  }
  for (const auto& [k, v] : b)
    if (!a.count(k)) return k + " extra";
  return "";
}

// One counted call of the log: its kind and the file it named.
struct Call {
  std::string kind, file;
};

std::vector<Call> read_log(const fs::path& log) {
  std::vector<Call> calls;
  std::ifstream in(log);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    long long n = 0;
    Call c;
    s >> n >> c.kind;
    std::getline(s >> std::ws, c.file);
    calls.push_back(c);
  }
  return calls;
}

// The file a call changes for a reader: a temporary's target is unchanged until its rename.
bool is_temporary(const std::string& name) {
  return name.size() > 1 && name[0] == '.' && name.find(".tmp.") != std::string::npos;
}

struct Scenario {
  std::string name;
  // Prepares the directory the command runs in (without faults).
  std::function<void(const fs::path& dir)> setup;
  std::string command;
  // The command that finishes the work once the fault is lifted, from the directory the fault left.
  std::function<std::string(const fs::path& dir)> rerun;
  // Files (relative to the directory) whose content the rerun must give as the run without a fault did.
  std::vector<std::string> results;
  // Whether the end-of-run compression of o.h5 is part of it (its failure leaves o.h5 complete with plain series).
  bool compresses = false;
};

// Whether the series of a run output are compressed (the end-of-run compression done).
bool series_compressed(const fs::path& h5) { return !H5File::open(h5).filters("/series/time").empty(); }

class WriteFaults : public testing::Test {
 protected:
  void SetUp() override {
    if (capsflow::test::capsflow_binary_path().empty()) GTEST_SKIP() << "CAPSFLOW_BINARY is not set";
  }

  static CliResult capsflow(const fs::path& dir, const std::string& args, const std::string& fault_env = "") {
    return run_capsflow(dir, args, 300, "OMP_NUM_THREADS=1 " + fault_env);
  }

  void copy_dir(const fs::path& from, const fs::path& to) const {
    fs::remove_all(to);
    fs::copy(from, to, fs::copy_options::recursive);
  }

  static std::map<std::string, std::string> results_of(const Scenario& s, const fs::path& dir) {
    std::map<std::string, std::string> m;
    for (std::string r : s.results) {
      // "DIR/*/NAME": the one file NAME below DIR (a sweep point's directory has a generated name).
      if (const std::size_t star = r.find("/*/"); star != std::string::npos) {
        const fs::path root = dir / r.substr(0, star);
        const std::string leaf = r.substr(star + 3);
        r = "<none below " + r.substr(0, star) + ">";
        if (fs::exists(root))
          for (const auto& e : fs::recursive_directory_iterator(root))
            if (e.path().filename() == leaf) r = fs::relative(e.path(), dir).string();
      }
      const fs::path p = dir / r;
      if (!fs::exists(p)) {
        m[r] = "<missing>";
      } else if (p.extension() == ".h5") {
        for (const auto& [k, v] : h5_content(p)) m[r + ":" + k] = v;
      } else {
        m[r] = slurp_file(p);
      }
    }
    return m;
  }

  // The whole sweep of one scenario; returns the number of counted calls.
  long long sweep(const Scenario& s) {
    const fs::path base = tmp_.path / "base";
    fs::create_directories(base);
    s.setup(base);
    const auto before = snapshot_files(base);

    // The run without a fault: its calls counted, its results the reference.
    const fs::path ref = tmp_.path / "reference";
    copy_dir(base, ref);
    const fs::path count_log = tmp_.path / "count.log";
    const CliResult clean =
        capsflow(ref, s.command, "CAPSFLOW_TEST_FAULT_LOG=" + shell_quote(count_log.string()));
    EXPECT_EQ(clean.status, 0) << clean.err;
    const std::vector<Call> all = read_log(count_log);
    const long long calls = static_cast<long long>(all.size());
    EXPECT_GT(calls, 0) << "no call counted: the injection is not reached";
    const auto want = results_of(s, ref);

    // Under LeakSanitizer: HDF5 1.10 keeps the buffers of a file whose close failed, and capsflow leaves them to the
    // end of the process (H5dont_atexit: HDF5's own exit handler crashes on such a file, h5_file.cpp). Those
    // allocations of the library are not reported for the faulted runs; the runs without a fault are checked in full.
    const fs::path suppressions = tmp_.path / "lsan.supp";
    write_text(suppressions, "leak:libhdf5\n");
    const std::string lsan = "LSAN_OPTIONS=suppressions=" + shell_quote(suppressions.string()) + ":print_suppressions=0 ";
    long long failed = 0, rerun = 0, others = 0, compression_faults = 0;
    for (long long n = 1; n <= calls && !HasFatalFailure(); ++n) {
      // (an HDF5 file, or the temporary of one: ".NAME.h5.tmp.PID.K")
      const bool hdf5_write =
          all[n - 1].kind == "write" && fs::path(all[n - 1].file).filename().string().find(".h5") != std::string::npos;
      const bool picked = hdf5_write ? n % kWriteStride == 0 : others % kOtherStride == 0;
      if (!hdf5_write) ++others;
      const bool sampled = full_sweep() || picked || n == calls;
      if (!sampled) continue;
      ++failed;
      const bool eio = n % 2 == 1;
      const std::string reason = eio ? "Input/output error" : "No space left on device";
      SCOPED_TRACE(s.name + ": call " + std::to_string(n) + " of " + std::to_string(calls) + " (" + all[n - 1].kind +
                   " " + all[n - 1].file + ", " + (eio ? "EIO" : "ENOSPC") + ")");
      const fs::path dir = tmp_.path / "n";
      copy_dir(base, dir);
      const fs::path log = tmp_.path / "n.log";
      fs::remove(log);
      const CliResult r = capsflow(dir, s.command,
                                   lsan + "CAPSFLOW_TEST_FAULT_AT=" + std::to_string(n) + " CAPSFLOW_TEST_FAULT_ERRNO=" +
                                       (eio ? "EIO" : "ENOSPC") + " CAPSFLOW_TEST_FAULT_LOG=" +
                                       shell_quote(log.string()));
      // One line, the system's reason in it.
      EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
      EXPECT_NE(r.err.find(reason), std::string::npos) << r.err;
      EXPECT_EQ(r.status, 1) << r.err;
      EXPECT_EQ(r.err.rfind("capsflow: error: ", 0), 0u) << r.err;
      // A failed end-of-run compression: the output as the run left it, every record in it, its series plain.
      if (s.compresses && r.err.find("cannot compress the series at the end of the run") != std::string::npos) {
        ++compression_faults;
        EXPECT_NE(r.err.find("o.h5: "), std::string::npos) << r.err;
        // Plain, unless only the directory's sync after the compressed file's rename failed.
        const bool renamed = n >= 2 && all[n - 2].kind == "rename" && fs::path(all[n - 2].file).filename() == "o.h5";
        EXPECT_EQ(series_compressed(dir / "o.h5"), renamed);
        std::map<std::string, std::string> plain;
        for (const auto& [k, v] : want)
          if (k.rfind("o.h5:", 0) == 0) plain[k] = v;
        std::map<std::string, std::string> got;
        for (const auto& [k, v] : h5_content(dir / "o.h5")) got["o.h5:" + k] = v;
        EXPECT_EQ(first_difference(plain, got), "") << "the output left by the failed compression is not complete";
      }
      // Nothing left behind: no temporary, no marker.
      const auto after = snapshot_files(dir);
      for (const auto& [name, content] : after) {
        const std::string leaf = fs::path(name).filename().string();
        EXPECT_FALSE(is_temporary(leaf)) << name;
        EXPECT_NE(fs::path(name).extension(), ".lock") << name;
      }
      // The files the command had not changed before the fault are as they were.
      const std::vector<Call> done = read_log(log);
      // The same calls as in the run without a fault up to N: the count is a property of the command.
      bool same = static_cast<long long>(done.size()) >= n;
      for (long long i = 0; same && i < n; ++i) same = done[i].kind == all[i].kind;
      if (!same) {
        ADD_FAILURE() << "the faulted run did not make the same first " << n << " calls as the run without a fault";
        break;
      }
      for (const auto& [name, content] : before) {
        bool changed = false;
        for (long long i = 0; i + 1 < n && i < static_cast<long long>(done.size()); ++i)
          changed = changed || fs::path(done[i].file).lexically_normal() == (dir / name).lexically_normal() ||
                    fs::path(done[i].file).filename() == fs::path(name).filename();
        if (changed || name.back() == '/') continue;
        const auto it = after.find(name);
        EXPECT_TRUE(it != after.end() && it->second == content) << name << " changed before the command wrote it";
      }
      if (!full_sweep() && (failed - 1) % kRerunStride != 0 && n != calls) continue;
      ++rerun;
      // The fault lifted: the rerun gives the results of the run that met none.
      const CliResult again = capsflow(dir, s.rerun(dir));
      EXPECT_EQ(again.status, 0) << again.err;
      const std::string diff = first_difference(want, results_of(s, dir));
      EXPECT_EQ(diff, "") << "the rerun differs from the run without a fault";
      if (s.compresses) {
        EXPECT_TRUE(series_compressed(dir / "o.h5")) << "the rerun left the series uncompressed";
      }
    }
    std::cout << "[ faults   ] " << s.name << ": " << calls << " counted calls; " << failed << " failed one by one, "
              << rerun << " of them rerun and compared" << (full_sweep() ? " (the full sweep)" : "");
    if (s.compresses) std::cout << "; " << compression_faults << " in the end-of-run compression";
    std::cout << "\n";
    // The compression's calls are the last of such a run (after its last checkpoint): the last call is one of them.
    if (s.compresses) {
      EXPECT_GT(compression_faults, 0) << "no fault met the end-of-run compression";
    }
    RecordProperty("counted_calls", std::to_string(calls));
    return calls;
  }

  TempDir tmp_;
};

// A new run from its start: its records and frames, its checkpoints, the XDMF index and the end-of-run compression.
TEST_F(WriteFaults, ARunFromItsStart) {
  Scenario s;
  s.name = "run from its start";
  s.setup = [](const fs::path& d) { write_text(d / "c.toml", tiny_config("o.h5")); };
  s.command = "run c.toml -q --progress 0";
  s.rerun = [](const fs::path& d) {
    return fs::exists(d / "o.checkpoint.h5") ? std::string("run --restart o.checkpoint.h5 -q --progress 0")
                                             : std::string("run c.toml -q --progress 0");
  };
  s.results = {"o.h5", "o.xdmf"};
  s.compresses = true;
  sweep(s);
}

// A compressed (finished) run continued: the unseal rewrites the output with plain series, then it grows again.
TEST_F(WriteFaults, TheContinuationOfACompressedRun) {
  Scenario s;
  s.name = "continuation of a compressed run";
  s.setup = [](const fs::path& d) {
    write_text(d / "c.toml", tiny_config("o.h5"));
    ASSERT_EQ(capsflow(d, "run c.toml -q --progress 0").status, 0);
  };
  s.command = "run --restart o.checkpoint.h5 --end 0.75 -q --progress 0";
  // A fault after the last checkpoint (at strain 0.75 or just past it): that checkpoint ends where the run ends, and
  // the restart takes its end from it (an --end below the checkpoint's strain is refused).
  s.rerun = [](const fs::path& d) {
    return read_checkpoint(d / "o.checkpoint.h5").state.time >= 0.75
               ? std::string("run --restart o.checkpoint.h5 -q --progress 0")
               : std::string("run --restart o.checkpoint.h5 --end 0.75 -q --progress 0");
  };
  s.results = {"o.h5", "o.xdmf"};
  s.compresses = true;
  sweep(s);
}

// `capsflow analyze` of a tiny run: analysis.h5 and the tables, staged and renamed together.
TEST_F(WriteFaults, AnalyzeOfATinyRun) {
  Scenario s;
  s.name = "analyze";
  s.setup = [](const fs::path& d) {
    write_text(d / "r" / "c.toml", tiny_config("o.h5"));
    ASSERT_EQ(capsflow(d / "r", "run c.toml -q --progress 0").status, 0);
  };
  s.command = "analyze r --out a -q";
  s.rerun = [](const fs::path&) { return std::string("analyze r --out a -q"); };
  s.results = {"a/analysis.h5", "a/curves.csv", "a/profiles.csv"};
  sweep(s);
}

// A sweep task: the point's config.toml and result files around its run.
TEST_F(WriteFaults, ASweepTask) {
  Scenario s;
  s.name = "sweep task";
  s.setup = [](const fs::path& d) {
    write_text(d / "base.toml", tiny_config("o.h5"));
    write_text(d / "s.toml", "base = \"base.toml\"\nroot = \"out\"\n[[point]]\nspecies.stiff.ca = 0.25\n");
  };
  s.command = "sweep s.toml --task 0";
  s.rerun = [](const fs::path&) { return std::string("sweep s.toml --task 0 --retry-failed"); };
  s.results = {"out/*/output.h5"};
  sweep(s);
}

// The reproducer on a real disk: a compressed run continued with 60 KiB left crashed inside HDF5 (SIGSEGV),
// leaving a temporary and OUT.lock. Now: exit 1, one line naming the output and the reason, the output unchanged,
// nothing left; with room made, the continuation gives what it gives on a large disk.
TEST_F(WriteFaults, ContinuingACompressedRunOnANearlyFullDisk) {
  SmallTmpfs m(tmp_.path / "m", "8m");
  if (!m.mounted) GTEST_SKIP() << m.why;
  write_text(m.dir / "c.toml", tiny_config("o.h5", ""));  // the configuration, its grid included
  ASSERT_EQ(capsflow(m.dir, "run c.toml --output o.h5 --progress 0 -q").status, 0);
  // The same continuation on the large disk: the reference.
  const fs::path big = tmp_.path / "big";
  fs::create_directories(big);
  for (const char* f : {"c.toml", "o.h5", "o.checkpoint.h5", "o.xdmf"}) fs::copy_file(m.dir / f, big / f);
  const std::string cont = "run --restart o.checkpoint.h5 --end 2.0 --progress 0 -q";
  ASSERT_EQ(capsflow(big, cont).status, 0);

  struct statvfs st {};
  ASSERT_EQ(::statvfs(m.dir.c_str(), &st), 0);
  const unsigned long long used = static_cast<unsigned long long>(st.f_blocks - st.f_bfree) * st.f_frsize;
  ASSERT_TRUE(m.grow(std::to_string(used + 61440)));
  const auto before = snapshot_files(m.dir);
  const CliResult r = capsflow(m.dir, cont);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find("o.h5: cannot rewrite it"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("left unchanged"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("No space left on device"), std::string::npos) << r.err;
  EXPECT_EQ(snapshot_files(m.dir), before);  // no temporary, no lock, the output and checkpoint as they were

  ASSERT_TRUE(m.grow("64m"));
  const CliResult again = capsflow(m.dir, cont);
  ASSERT_EQ(again.status, 0) << again.err;
  EXPECT_EQ(first_difference(h5_content(big / "o.h5"), h5_content(m.dir / "o.h5")), "");
  EXPECT_EQ(slurp_file(big / "o.xdmf"), slurp_file(m.dir / "o.xdmf"));
}

}  // namespace
