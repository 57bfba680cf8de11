#pragma once
// XDMF index of a run's HDF5 output, so that ParaView opens the capsule surfaces as a time series.
//
// The XDMF file is light data only: a temporal collection with one uniform grid per frame. Every grid
// shares the triangle connectivity (a static [Ntri, 3] integer dataset, all capsules' triangles with
// global node numbers) and takes its node coordinates from frame f of the extendable dataset
// [F, Nnodes, 3] through a HyperSlab DataItem (start f 0 0, stride 1 1 1, count 1 Nnodes 3). Attributes
// are either static (one [N] or [N, 3] dataset, e.g. the species of each node) or per frame (a hyperslab
// of an [F, N] or [F, N, 3] dataset, e.g. node velocities).
//
// With `walls` set, every frame is a spatial collection of three uniform grids: "capsules" (as above), "walls" (the
// planes y = 0 and y = H over the periodic box, two quadrilaterals) and "box" (the 12 edges of [0, Lx] x [0, H] x
// [0, Lz] as two-node polylines). Their 8 corner points are inline XML, so they need no HDF5 data. A walls grid
// beside the temporal collection instead would be dropped by ParaView's Xdmf3ReaderS/T (5.11); this form shows in
// all three of its readers, as a multiblock per time step.
//
// The HDF5 file is referenced by its file name only ("run.h5:/frames/positions"), i.e. relative to the
// XDMF file, so the output directory can be moved or copied as a whole.
//
// Usage (run loop):
//   XdmfSeries s;
//   s.h5_file_name = "run.h5";
//   s.triangles = {"/mesh/triangles_all", {ntri, 3}, XdmfNumber::Int32};
//   s.positions_path = "/frames/positions"; s.n_nodes = nnodes;
//   s.attributes.push_back({"species", XdmfCenter::Node, {"/mesh/node_species", {nnodes}, XdmfNumber::Int32}, false});
//   XdmfWriter xdmf(dir / "run.xdmf", s);
//   each frame: h5.append("/frames/positions", x, {nnodes, 3}); h5.flush(); xdmf.add_frame(t);
//   restart:    h5.truncate("/frames/positions", nf); xdmf.set_frame_times(first nf times);
//
// The file is rewritten atomically (write_file_atomically) after each frame, so a viewer or a crash never
// sees a half-written index. Write it after flushing the HDF5 file, so every frame it lists is on disk.
#include <functional>
#include <optional>
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace capsflow {

enum class XdmfNumber { Float64, Float32, Int32, Int64 };
enum class XdmfCenter { Node, Cell };

// One HDF5 dataset as XDMF sees it: path inside the HDF5 file, shape, element type.
struct XdmfDataset {
  std::string h5_path;            // absolute path inside the HDF5 file, e.g. "/mesh/node_species"
  std::vector<std::size_t> dims;  // static: the whole shape; time-varying: the shape of ONE frame
  XdmfNumber number = XdmfNumber::Float64;
};

struct XdmfAttribute {
  std::string name;                      // shown in ParaView
  XdmfCenter center = XdmfCenter::Node;  // Node: dims[0] = n_nodes; Cell: dims[0] = number of triangles
  XdmfDataset data;                      // dims [N] (Scalar) or [N, 3] (Vector)
  bool per_frame = false;                // true: data.h5_path is [F, dims...] and frame f is used
};

// The slit's periodic box [0, Lx] x [0, H] x [0, Lz] (walls at y = 0 and y = H).
struct XdmfBox {
  double Lx = 0.0, H = 0.0, Lz = 0.0;
};

struct XdmfSeries {
  std::string h5_file_name;                           // file name only (same directory as the XDMF file)
  std::string grid_name = "capsules";                 // name of the temporal collection
  XdmfDataset triangles{"/mesh/triangles_all", {}, XdmfNumber::Int32};  // dims [Ntri, 3]
  std::string positions_path = "/frames/positions";   // [F, n_nodes, 3]
  XdmfNumber positions_number = XdmfNumber::Float64;
  std::size_t n_nodes = 0;
  std::vector<XdmfAttribute> attributes;
  std::optional<XdmfBox> walls;                        // set: every frame also shows the walls and the box
  // Set: frame f of a per-frame dataset P is referred to as the plain dataset frame_view(P, f) (HDF5 virtual
  // datasets of the writer's making, e.g. run_layout's frame_view_path) instead of a HyperSlab of P, which
  // ParaView's Xdmf3ReaderS/T do not read (5.11 shows 0 points). Unset: HyperSlabs (format versions < 3).
  std::function<std::string(const std::string& h5_path, std::size_t frame)> frame_view;
};

// Throws std::invalid_argument if the description is inconsistent (empty or non-plain file name, triangle
// dims not [N, 3], attribute shapes not matching the node or cell count, ...).
void validate(const XdmfSeries& series);

// The XDMF 3 document for frames 0..times.size()-1 (frame f at times[f]). Validates first.
std::string render_xdmf(const XdmfSeries& series, const std::vector<double>& frame_times);

// render_xdmf written atomically to `path`.
void write_xdmf(const std::filesystem::path& path, const XdmfSeries& series, const std::vector<double>& frame_times);

// Keeps the frame times of a run and rewrites the XDMF file whenever they change.
class XdmfWriter {
 public:
  XdmfWriter(std::filesystem::path path, XdmfSeries series);  // validates; writes nothing yet

  // Frame frame_count() now holds data at `time`; rewrites the file.
  void add_frame(double time);
  // Replaces all frame times (e.g. read back from /frames/time after a restart truncated the run); rewrites.
  void set_frame_times(std::vector<double> times);
  void write() const;

  std::size_t frame_count() const { return times_.size(); }
  const std::vector<double>& frame_times() const { return times_; }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  XdmfSeries series_;
  std::vector<double> times_;
};

}  // namespace capsflow
