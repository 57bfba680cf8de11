#pragma once
// `capsflow flow RUN.h5 [--frame N] --plane z=VALUE | --points FILE --out FLOW.h5`: the fluid velocity of a run's
// frame at the grid points of a plane or at given points (flow_field.hpp: the solver's own operator), written as
// FLOW.h5 with its ParaView index FLOW.xdmf and, for a plane, a picture FLOW.png drawn by tools/capsflow_flow.py
// (matplotlib, found and run as `capsflow figures` runs its script). docs/usage.md "capsflow flow".
#include <iosfwd>
#include <optional>
#include <string>

namespace CLI {
class App;
}

namespace capsflow {

struct FlowCommandOptions {
  std::string run;                     // RUN.h5
  std::optional<long> frame;           // --frame N (0 the first, negative from the end; unset: the last)
  std::string plane;                   // --plane x=V | y=V | z=V
  std::string points;                  // --points FILE.csv (header x,y,z)
  double spacing = 0.1;                // --spacing: the plane's grid step (a)
  std::string out;                     // --out FLOW.h5 (FLOW.xdmf and FLOW.png beside it)
  std::optional<std::string> backend;  // --backend serial | threads (the run's, unless device: then threads)
  std::optional<int> threads;          // --threads N
  bool force = false;
  bool quiet = false;
};

CLI::App* add_flow(CLI::App& app, FlowCommandOptions& o);

// Exit status 0 (the PNG skipped with a note when no python3 with matplotlib is found); InputError for bad input,
// before any file is written.
int run_flow(const FlowCommandOptions& o, std::ostream& log);

}  // namespace capsflow
