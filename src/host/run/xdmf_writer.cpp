// The implementation of xdmf_writer.hpp: the XDMF index through which ParaView opens a run's frames.
#include "host/run/xdmf_writer.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "host/base/atomic_file.hpp"

namespace capsflow {

namespace {

const char* number_type(XdmfNumber n) {
  switch (n) {
    case XdmfNumber::Float64:
    case XdmfNumber::Float32: return "Float";
    case XdmfNumber::Int32:
    case XdmfNumber::Int64: return "Int";
  }
  return "Float";
}

int precision(XdmfNumber n) {
  switch (n) {
    case XdmfNumber::Float64:
    case XdmfNumber::Int64: return 8;
    case XdmfNumber::Float32:
    case XdmfNumber::Int32: return 4;
  }
  return 8;
}

std::string escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string join(const std::vector<std::size_t>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? " " : "") + std::to_string(v[i]);
  return s;
}

// Shortest text that reads back as the same double.
std::string format_time(double t) {
  char buf[40];
  for (int p = 15; p <= 17; ++p) {
    std::snprintf(buf, sizeof buf, "%.*g", p, t);
    if (std::strtod(buf, nullptr) == t) break;
  }
  return buf;
}

std::string heavy(const XdmfSeries& s, const std::string& h5_path) { return escape(s.h5_file_name + ":" + h5_path); }

// <DataItem> for a whole dataset.
void data_item(std::ostream& os, const std::string& indent, const XdmfSeries& s, const XdmfDataset& d) {
  os << indent << "<DataItem Dimensions=\"" << join(d.dims) << "\" NumberType=\"" << number_type(d.number)
     << "\" Precision=\"" << precision(d.number) << "\" Format=\"HDF\">" << heavy(s, d.h5_path) << "</DataItem>\n";
}

// <DataItem ItemType="HyperSlab"> selecting frame f of a [F, inner...] dataset.
void frame_slab(std::ostream& os, const std::string& indent, const XdmfSeries& s, const std::string& h5_path,
                const std::vector<std::size_t>& inner, XdmfNumber number, std::size_t f, std::size_t n_frames) {
  if (s.frame_view) {
    data_item(os, indent, s, XdmfDataset{s.frame_view(h5_path, f), inner, number});
    return;
  }
  std::vector<std::size_t> count{1}, start{f}, stride{1}, full{n_frames};
  for (std::size_t d : inner) {
    count.push_back(d);
    start.push_back(0);
    stride.push_back(1);
    full.push_back(d);
  }
  os << indent << "<DataItem ItemType=\"HyperSlab\" Dimensions=\"" << join(count) << "\" Type=\"HyperSlab\">\n"
     << indent << "  <DataItem Dimensions=\"3 " << count.size() << "\" NumberType=\"Int\" Format=\"XML\">" << join(start)
     << "  " << join(stride) << "  " << join(count) << "</DataItem>\n"
     << indent << "  <DataItem Dimensions=\"" << join(full) << "\" NumberType=\"" << number_type(number)
     << "\" Precision=\"" << precision(number) << "\" Format=\"HDF\">" << heavy(s, h5_path) << "</DataItem>\n"
     << indent << "</DataItem>\n";
}

// The walls and box grids of one frame (see the header): 8 corners, corner 4 ix + 2 iy + iz at (ix Lx, iy H, iz Lz).
void walls_grids(std::ostream& os, const std::string& indent, const XdmfBox& b) {
  std::string corners;
  for (int i = 0; i < 8; ++i)
    corners += (i ? "  " : "") + format_time((i & 4) ? b.Lx : 0.0) + " " + format_time((i & 2) ? b.H : 0.0) + " " +
               format_time((i & 1) ? b.Lz : 0.0);
  auto grid = [&](const char* name, const std::string& topology, const char* cells) {
    os << indent << "<Grid Name=\"" << name << "\" GridType=\"Uniform\">\n"
       << indent << "  " << topology << "\n"
       << indent << "    <DataItem Dimensions=\"" << cells << "\" NumberType=\"Int\" Precision=\"4\" Format=\"XML\">";
  };
  auto geometry = [&] {
    os << indent << "  <Geometry GeometryType=\"XYZ\">\n"
       << indent << "    <DataItem Dimensions=\"8 3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">" << corners
       << "</DataItem>\n"
       << indent << "  </Geometry>\n"
       << indent << "</Grid>\n";
  };
  grid("walls", "<Topology TopologyType=\"Quadrilateral\" NumberOfElements=\"2\">", "2 4");
  os << "0 1 5 4  2 6 7 3</DataItem>\n" << indent << "  </Topology>\n";
  geometry();
  grid("box", "<Topology TopologyType=\"Polyline\" NodesPerElement=\"2\" NumberOfElements=\"12\">", "12 2");
  os << "0 4  1 5  2 6  3 7  0 2  1 3  4 6  5 7  0 1  2 3  4 5  6 7</DataItem>\n" << indent << "  </Topology>\n";
  geometry();
}

[[noreturn]] void bad(const std::string& msg) { throw std::invalid_argument("XDMF series: " + msg); }

}  // namespace

void validate(const XdmfSeries& s) {
  if (s.h5_file_name.empty()) bad("no HDF5 file name");
  if (s.h5_file_name.find('/') != std::string::npos || s.h5_file_name == "." || s.h5_file_name == "..")
    bad("the HDF5 file must be named by its file name only (relative to the XDMF file), got '" + s.h5_file_name + "'");
  if (s.h5_file_name.find(':') != std::string::npos) bad("the HDF5 file name cannot contain ':'");
  if (s.triangles.dims.size() != 2 || s.triangles.dims[1] != 3) bad("triangles must have dims [Ntri, 3]");
  if (s.triangles.number != XdmfNumber::Int32 && s.triangles.number != XdmfNumber::Int64)
    bad("triangles must be integers");
  if (s.n_nodes == 0) bad("n_nodes is 0");
  auto check_path = [](const std::string& p, const std::string& what) {
    if (p.empty() || p[0] != '/') bad(what + ": HDF5 path must be absolute, got '" + p + "'");
  };
  if (s.walls && !(s.walls->Lx > 0.0 && s.walls->H > 0.0 && s.walls->Lz > 0.0 && std::isfinite(s.walls->Lx) &&
                   std::isfinite(s.walls->H) && std::isfinite(s.walls->Lz)))
    bad("the walls' box must have finite sides > 0");
  check_path(s.triangles.h5_path, "triangles");
  check_path(s.positions_path, "positions");
  for (const XdmfAttribute& a : s.attributes) {
    check_path(a.data.h5_path, "attribute '" + a.name + "'");
    if (a.name.empty()) bad("an attribute has no name");
    const std::size_t expected = a.center == XdmfCenter::Node ? s.n_nodes : s.triangles.dims[0];
    const auto& d = a.data.dims;
    if (d.empty() || d.size() > 2 || d[0] != expected || (d.size() == 2 && d[1] != 3 && d[1] != 1))
      bad("attribute '" + a.name + "': dims must be [" + std::to_string(expected) + "] or [" +
          std::to_string(expected) + ", 3]");
  }
}

std::string render_xdmf(const XdmfSeries& s, const std::vector<double>& times) {
  validate(s);
  const std::size_t nf = times.size();
  const std::size_t ntri = s.triangles.dims[0];
  std::ostringstream os;
  os << "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n"
     << "<Xdmf xmlns:xi=\"http://www.w3.org/2001/XInclude\" Version=\"3.0\">\n"
     << "  <Domain>\n"
     << "    <Grid Name=\"" << escape(s.grid_name) << "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  // With walls, the capsules' grid sits one level deeper, in the frame's spatial collection.
  const std::string in = s.walls ? "          " : "        ";
  for (std::size_t f = 0; f < nf; ++f) {
    if (s.walls) {
      os << "      <Grid Name=\"frame_" << f << "\" GridType=\"Collection\" CollectionType=\"Spatial\">\n"
         << "        <Time Value=\"" << format_time(times[f]) << "\"/>\n"
         << "        <Grid Name=\"capsules\" GridType=\"Uniform\">\n";
    } else {
      os << "      <Grid Name=\"frame_" << f << "\" GridType=\"Uniform\">\n"
         << in << "<Time Value=\"" << format_time(times[f]) << "\"/>\n";
    }
    os << in << "<Topology TopologyType=\"Triangle\" NumberOfElements=\"" << ntri << "\">\n";
    data_item(os, in + "  ", s, s.triangles);
    os << in << "</Topology>\n" << in << "<Geometry GeometryType=\"XYZ\">\n";
    frame_slab(os, in + "  ", s, s.positions_path, {s.n_nodes, 3}, s.positions_number, f, nf);
    os << in << "</Geometry>\n";
    for (const XdmfAttribute& a : s.attributes) {
      const bool vector = a.data.dims.size() == 2 && a.data.dims[1] == 3;
      os << in << "<Attribute Name=\"" << escape(a.name) << "\" AttributeType=\"" << (vector ? "Vector" : "Scalar")
         << "\" Center=\"" << (a.center == XdmfCenter::Node ? "Node" : "Cell") << "\">\n";
      if (a.per_frame)
        frame_slab(os, in + "  ", s, a.data.h5_path, a.data.dims, a.data.number, f, nf);
      else
        data_item(os, in + "  ", s, a.data);
      os << in << "</Attribute>\n";
    }
    if (s.walls) {
      os << "        </Grid>\n";
      walls_grids(os, "        ", *s.walls);
    }
    os << "      </Grid>\n";
  }
  os << "    </Grid>\n"
     << "  </Domain>\n"
     << "</Xdmf>\n";
  return os.str();
}

void write_xdmf(const std::filesystem::path& path, const XdmfSeries& series, const std::vector<double>& frame_times) {
  write_file_atomically(path, render_xdmf(series, frame_times));
}

XdmfWriter::XdmfWriter(std::filesystem::path path, XdmfSeries series) : path_(std::move(path)), series_(std::move(series)) {
  validate(series_);
}

void XdmfWriter::add_frame(double time) {
  times_.push_back(time);
  try {
    write();
  } catch (...) {
    times_.pop_back();  // keep the writer consistent with what is on disk
    throw;
  }
}

void XdmfWriter::set_frame_times(std::vector<double> times) {
  times_ = std::move(times);
  write();
}

void XdmfWriter::write() const { write_xdmf(path_, series_, times_); }

}  // namespace capsflow
