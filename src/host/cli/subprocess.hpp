#pragma once
// Running helper programs (python3 for `capsflow figures`, pvbatch, xvfb-run and ffmpeg for `capsflow render`): no
// shell, argv passed as it is, the child waited for.
//
// Usage:
//   ProcessOptions o;
//   o.on_line = [&](const std::string& line) { ... };   // the child's stdout, line by line (progress)
//   o.stderr_file = tmp / "pvbatch.log";
//   const ProcessResult r = run_process({"pvbatch", "script.py", "job.json"}, o);
//   if (!r.started) ... strerror(r.error) ...; else if (r.status != 0) ...
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace capsflow {

struct ProcessOptions {
  bool capture_stdout = false;                         // collect the child's stdout in ProcessResult::out
  std::function<void(const std::string&)> on_line;     // or hand it over line by line (without the newline)
  bool discard_stderr = false;                         // the child's stderr to /dev/null
  std::filesystem::path stderr_file;                   // or to this file (created or truncated)
};

struct ProcessResult {
  bool started = false;  // false: the program could not be run (`error` is the errno, e.g. ENOENT)
  int error = 0;
  int status = -1;       // exit status, 128 + signal if killed
  std::string out;       // stdout, with capture_stdout
};

// Runs argv[0] (looked up on PATH when it has no '/') with argv and waits for it. Without capture_stdout or on_line
// the child shares our stdout; without discard_stderr or stderr_file, our stderr.
ProcessResult run_process(const std::vector<std::string>& argv, const ProcessOptions& options = {});

// The first executable regular file `name` in the directories of $PATH (or `name` itself when it holds a '/' and is
// executable); empty when there is none.
std::string find_program(const std::string& name);

}  // namespace capsflow
