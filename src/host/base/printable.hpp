#pragma once
// A user's string as a one-line message shows it: control characters spelled out (\n, \r, \t, else \xHH), so that
// the error line names what was given without breaking the line (config keys, sweep values, Slurm options).
#include <string>

namespace capsflow {

std::string printable(const std::string& s);

// A number in messages: printf's %.<digits>g (the one formatter behind the files' local num()).
std::string format_significant(double v, int digits);

}  // namespace capsflow
