#pragma once
// `capsflow render RUN.h5 --out DIR`: 3D pictures of a run's capsules at chosen frames (the last by default), coloured
// by species or by a membrane field, with the walls, the periodic box and a colour bar; `--movie` an MP4 of the run;
// always a ParaView state of the same view (docs/usage.md, "capsflow render").
//
// The drawing is ParaView's: tools/capsflow_render.py run by pvbatch (Debian's paraview + python3-paraview), found
// like the figure script (<exe dir>/share/capsflow, then <exe dir>/../share/capsflow). This side checks everything
// first (the run file, its XDMF index beside it, the options, the programs), computes the colour range, then runs
// pvbatch on a job file; the movie is encoded by ffmpeg. Which pvbatch: $CAPSFLOW_PVBATCH if set (and only that), else
// `pvbatch` on PATH. Offscreen: Debian's pvbatch draws through an X server, so without $DISPLAY it runs under xvfb-run
// (Debian's xvfb); a $CAPSFLOW_PVBATCH built for offscreen rendering (EGL, OSMesa) runs without one when xvfb-run is
// absent.
//
// Outputs go to a hidden temporary directory in DIR first and are renamed into place together at the end, all or none
// (a failure part way puts back what was there); an existing output is refused (status 2, nothing written) unless
// `force`, a directory where one goes even with it. DIR/render.lock (run_marker.hpp, FolderLock) keeps a second render
// out of DIR meanwhile, whatever `force` says. pvbatch (with xvfb-run and its Xvfb) and ffmpeg run in a process group
// of their own that ends with capsflow: a SIGINT, SIGTERM, SIGHUP or SIGQUIT ends the group and capsflow exits 128 +
// signal, and a capsflow killed outright has the group ended by a watchdog (subprocess.hpp).
//
// Usage (src/host/cli/main.cpp):
//   RenderOptions ro;
//   CLI::App* render = add_render(app, ro);
//   if (render->parsed()) return run_render(ro, std::cerr);   // 0 done, 2 input error, 1 pvbatch or ffmpeg failed,
//                                                             // 128 + signal when stopped by one
#include <ostream>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace capsflow {

struct RenderOptions {
  std::string run;                  // RUN.h5 (OUT.xdmf beside it)
  std::string out;                  // --out DIR
  std::vector<long> frames;         // --frame I: frame index, negative from the end (-1: the last)
  std::vector<double> times;        // --time T: the frame nearest strain T
  std::string color = "species";    // --color
  std::string range;                // --range LO:HI of a field's colour map (default: its min..max over the frames)
  std::string size = "1280x720";    // --size WxH in pixels
  std::string view = "side";        // --view: side (along z), top (along y) or oblique; side and top orthographic
  bool movie = false;               // --movie: an MP4 of every frame (every `stride`-th)
  int fps = 10;                     // --fps
  int stride = 1;                   // --stride
  bool force = false;               // --force: replace existing outputs
  bool quiet = false;               // -q: no progress, no summary
};

// The `render` subcommand with its options and their checks.
CLI::App* add_render(CLI::App& app, RenderOptions& o);

// Draws what `o` asks for; progress and the summary go to `log`. InputError for bad input, a missing program (naming
// the Debian package) or an existing output without force; 1 when pvbatch or ffmpeg fails (one line naming it); 128 +
// signal when a signal stopped it while pvbatch or ffmpeg ran (their process group ended, nothing written).
int run_render(const RenderOptions& o, std::ostream& log);

}  // namespace capsflow
