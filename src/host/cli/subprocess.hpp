#pragma once
// Running helper programs (python3 for `capsflow figures`, pvbatch, xvfb-run and ffmpeg for `capsflow render`): no
// shell, argv passed as it is, the child waited for.
//
// With `own_group` the child and everything it starts (xvfb-run's Xvfb, pvbatch) end with this process:
//   - the child leads a process group of its own, with /dev/null as its stdin (a background group reading the
//     terminal would stop), and so does not see the terminal's Ctrl-C itself;
//   - a SIGINT, SIGTERM, SIGHUP or SIGQUIT that reaches this process while it waits is passed on to the whole group as
//     SIGTERM, SIGKILL follows after kGroupGraceSeconds, and run_process returns with ProcessResult::signal set (the
//     caller cleans up and exits 128 + signal);
//   - when the child is done, whatever it left running in its group is ended the same way (TERM, then KILL);
//   - if this process is killed outright (SIGKILL, which no handler sees), a watchdog ends the group: a fork of this
//     process in the child's group, holding the read end of a pipe whose write end only this process holds; when
//     that pipe reports end-of-file it sends the group SIGTERM, then SIGKILL after the grace. The child also gets
//     SIGTERM from the kernel when this process dies (PR_SET_PDEATHSIG, Linux). What escapes: a descendant that
//     leaves the group (setsid, setpgid: a daemon), and a watchdog itself killed by name.
//
// Usage:
//   ProcessOptions o;
//   o.on_line = [&](const std::string& line) { ... };   // the child's stdout, line by line (progress)
//   o.stderr_file = tmp / "pvbatch.log";
//   o.own_group = true;
//   const ProcessResult r = run_process({"pvbatch", "script.py", "job.json"}, o);
//   if (!r.started) ... strerror(r.error) ...; else if (r.signal) ... return 128 + r.signal; else if (r.status) ...
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace capsflow {

// Seconds between the SIGTERM to an own_group child's group and the SIGKILL to what is left of it.
inline constexpr double kGroupGraceSeconds = 2.0;

struct ProcessOptions {
  bool capture_stdout = false;                         // collect the child's stdout in ProcessResult::out
  std::function<void(const std::string&)> on_line;     // or hand it over line by line (without the newline)
  bool discard_stderr = false;                         // the child's stderr to /dev/null
  std::filesystem::path stderr_file;                   // or to this file (created or truncated)
  bool own_group = false;                              // the child ends with this process (above)
};

struct ProcessResult {
  bool started = false;  // false: the program could not be run (`error` is the errno, e.g. ENOENT)
  int error = 0;
  int status = -1;       // exit status, 128 + signal if killed
  int signal = 0;        // own_group: the signal this process received while waiting (its child's group was ended)
  std::string out;       // stdout, with capture_stdout
};

// Runs argv[0] (looked up on PATH when it has no '/') with argv and waits for it. Without capture_stdout or on_line
// the child shares our stdout; without discard_stderr or stderr_file, our stderr.
ProcessResult run_process(const std::vector<std::string>& argv, const ProcessOptions& options = {});

// The first executable regular file `name` in the directories of $PATH (or `name` itself when it holds a '/' and is
// executable); empty when there is none.
std::string find_program(const std::string& name);

}  // namespace capsflow
