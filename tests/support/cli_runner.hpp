#pragma once
// Test helper: runs the capsflow executable (env CAPSFLOW_BINARY, else the path compiled in by tests/CMakeLists.txt)
// in a working directory and captures its exit status, stdout and stderr. A command that outlives `timeout_s` is
// killed (status 124, as timeout(1) reports it), so a hang fails the test instead of stalling the suite.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <initializer_list>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>

#ifndef CAPSFLOW_TEST_DEFAULT_BINARY
#define CAPSFLOW_TEST_DEFAULT_BINARY nullptr
#endif

namespace capsflow::test {

inline std::string capsflow_binary_path() {
  const char* v = std::getenv("CAPSFLOW_BINARY");
  if (v && *v) return v;
  const char* d = CAPSFLOW_TEST_DEFAULT_BINARY;
  return d ? d : "";
}

struct CliResult {
  int status = -1;  // exit status; 128 + signal when killed by a signal; 124 on timeout
  std::string out, err;
};

inline std::string slurp_file(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Single quotes for the shell.
inline std::string shell_quote(const std::string& s) {
  std::string o = "'";
  for (char c : s) o += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return o + "'";
}

// `args` is shell text (quote arguments with shell_quote). stdout/stderr go to files beside `work`. `env` is shell
// text put before the command (variable assignments, or e.g. "ulimit -v 6000000;"); OMP_NUM_THREADS=2 by default.
// `redirect` replaces the standard redirections (e.g. "2>&-" to start the program with stderr closed).
inline CliResult run_capsflow(const std::filesystem::path& work, const std::string& args, int timeout_s = 120,
                              const std::string& env = "OMP_NUM_THREADS=2", const std::string& redirect = "") {
  const std::filesystem::path out = work.parent_path() / (work.filename().string() + ".stdout"),
                              err = work.parent_path() / (work.filename().string() + ".stderr");
  const std::string streams = redirect.empty() ? " >" + shell_quote(out.string()) + " 2>" +
                                                     shell_quote(err.string()) + " </dev/null"
                                               : " >" + shell_quote(out.string()) + " " + redirect + " </dev/null";
  const std::string cmd = "cd " + shell_quote(work.string()) + " && " + env + " timeout -s KILL " +
                          std::to_string(timeout_s) + " " + shell_quote(capsflow_binary_path()) + " " + args + streams;
  const int raw = std::system(cmd.c_str());
  CliResult r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  if (r.status == 137) r.status = 124;  // timeout -s KILL: the command hung
  r.out = slurp_file(out);
  r.err = slurp_file(err);
  return r;
}

// An input error as the docs promise it: status 2, exactly one line "capsflow: error: ...", naming every one of
// `parts` (the key, option or file and what was expected).
inline void expect_input_error(const CliResult& r, std::initializer_list<std::string> parts) {
  EXPECT_EQ(r.status, 2) << r.err << r.out;
  EXPECT_EQ(r.err.rfind("capsflow: error: ", 0), 0u) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  for (const auto& p : parts) EXPECT_NE(r.err.find(p), std::string::npos) << "'" << p << "' not in: " << r.err;
}

// Every regular file under `dir` with its content: to assert that a refused command created or changed nothing.
inline std::map<std::string, std::string> snapshot_files(const std::filesystem::path& dir) {
  std::map<std::string, std::string> m;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir))
    if (e.is_regular_file()) {
      m[std::filesystem::relative(e.path(), dir).string()] = slurp_file(e.path());
    } else if (e.is_directory()) {
      m[std::filesystem::relative(e.path(), dir).string() + "/"] = "";
    }
  return m;
}

}  // namespace capsflow::test
