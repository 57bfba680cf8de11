// XDMF index: well-formed XML, one uniform grid per frame, hyperslabs that match the HDF5 datasets, HDF5
// file named relative to the XDMF file. xmllint checks well-formedness too where it is installed.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "host/base/h5_file.hpp"
#include "host/run/xdmf_writer.hpp"
#include "support/temp_dir.hpp"

namespace capsflow::test {
namespace {

namespace fs = std::filesystem;



// --- a minimal XML reader: elements, attributes, text; throws on unbalanced or malformed tags ----------
struct Element {
  std::string name;
  std::map<std::string, std::string> attrs;
  std::string text;
  std::vector<std::unique_ptr<Element>> children;

  std::vector<const Element*> all(const std::string& n) const {  // descendants named n, document order
    std::vector<const Element*> out;
    for (const auto& c : children) {
      if (c->name == n) out.push_back(c.get());
      auto sub = c->all(n);
      out.insert(out.end(), sub.begin(), sub.end());
    }
    return out;
  }
  const Element& child(const std::string& n) const {
    for (const auto& c : children)
      if (c->name == n) return *c;
    throw std::runtime_error("no <" + n + "> in <" + name + ">");
  }
  std::string attr(const std::string& k) const {
    auto it = attrs.find(k);
    if (it == attrs.end()) throw std::runtime_error("no attribute " + k + " on <" + name + ">");
    return it->second;
  }
};

std::string unescape(const std::string& s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] != '&') {
      out += s[i];
      continue;
    }
    const std::size_t end = s.find(';', i);
    if (end == std::string::npos) throw std::runtime_error("bad entity");
    const std::string e = s.substr(i + 1, end - i - 1);
    const std::map<std::string, char> known = {{"amp", '&'}, {"lt", '<'}, {"gt", '>'}, {"quot", '"'}, {"apos", '\''}};
    if (!known.count(e)) throw std::runtime_error("unknown entity &" + e + ";");
    out += known.at(e);
    i = end;
  }
  return out;
}

std::unique_ptr<Element> parse_xml(const std::string& xml) {
  auto root = std::make_unique<Element>();
  root->name = "#document";
  std::vector<Element*> stack{root.get()};
  std::size_t i = 0;
  while (i < xml.size()) {
    const std::size_t lt = xml.find('<', i);
    const std::string text = xml.substr(i, lt == std::string::npos ? std::string::npos : lt - i);
    if (text.find('>') != std::string::npos) throw std::runtime_error("stray '>'");
    stack.back()->text += unescape(text);
    if (lt == std::string::npos) break;
    const std::size_t gt = xml.find('>', lt);
    if (gt == std::string::npos) throw std::runtime_error("unterminated tag");
    std::string tag = xml.substr(lt + 1, gt - lt - 1);
    i = gt + 1;
    if (tag.empty()) throw std::runtime_error("empty tag");
    if (tag[0] == '?' || tag[0] == '!') continue;  // declaration, comment (no '>' inside ours)
    if (tag[0] == '/') {
      if (stack.size() < 2 || stack.back()->name != tag.substr(1))
        throw std::runtime_error("unbalanced </" + tag.substr(1) + ">");
      stack.pop_back();
      continue;
    }
    const bool self_closing = tag.back() == '/';
    if (self_closing) tag.pop_back();
    auto el = std::make_unique<Element>();
    std::istringstream is(tag);
    is >> el->name;
    std::size_t pos = el->name.size();
    while (true) {
      pos = tag.find_first_not_of(" \t\n", pos);
      if (pos == std::string::npos) break;
      const std::size_t eq = tag.find('=', pos);
      if (eq == std::string::npos || eq + 1 >= tag.size() || tag[eq + 1] != '"')
        throw std::runtime_error("bad attribute in <" + tag + ">");
      const std::size_t close = tag.find('"', eq + 2);
      if (close == std::string::npos) throw std::runtime_error("unterminated attribute in <" + tag + ">");
      const std::string key = tag.substr(pos, eq - pos);
      if (!el->attrs.emplace(key, unescape(tag.substr(eq + 2, close - eq - 2))).second)
        throw std::runtime_error("duplicate attribute " + key);
      pos = close + 1;
    }
    Element* raw = el.get();
    stack.back()->children.push_back(std::move(el));
    if (!self_closing) stack.push_back(raw);
  }
  if (stack.size() != 1) throw std::runtime_error("unclosed <" + stack.back()->name + ">");
  if (root->children.size() != 1) throw std::runtime_error("not exactly one root element");
  return root;
}

std::vector<std::size_t> numbers(const std::string& s) {
  std::istringstream is(s);
  std::vector<std::size_t> v;
  std::size_t x;
  while (is >> x) v.push_back(x);
  return v;
}

// "run.h5:/frames/positions" -> ("run.h5", "/frames/positions")
std::pair<std::string, std::string> split_heavy(std::string s) {
  const auto b = s.find_first_not_of(" \n\t"), e = s.find_last_not_of(" \n\t");
  s = s.substr(b, e - b + 1);
  const auto colon = s.find(':');
  return {s.substr(0, colon), s.substr(colon + 1)};
}

bool have_xmllint() { return std::system("command -v xmllint > /dev/null 2>&1") == 0; }

// Two tetrahedral "capsules": 8 nodes, 8 triangles, global node numbering.
struct Fixture {
  static constexpr std::size_t kNodes = 8, kTris = 8;
  XdmfSeries series() const {
    XdmfSeries s;
    s.h5_file_name = "run.h5";
    s.triangles = {"/mesh/triangles_all", {kTris, 3}, XdmfNumber::Int32};
    s.positions_path = "/frames/positions";
    s.n_nodes = kNodes;
    s.attributes.push_back({"species", XdmfCenter::Node, {"/mesh/node_species", {kNodes}, XdmfNumber::Int32}, false});
    s.attributes.push_back({"tension", XdmfCenter::Cell, {"/frames/tension", {kTris}, XdmfNumber::Float64}, true});
    return s;
  }
  void write_h5(const fs::path& p, std::size_t frames) const {
    auto f = H5File::create(p, true);
    std::vector<std::int32_t> tri;
    for (std::int32_t c = 0; c < 2; ++c)
      for (std::int32_t t : {0, 1, 2, 0, 3, 1, 1, 3, 2, 2, 3, 0}) tri.push_back(4 * c + t);
    f.write("/mesh/triangles_all", {kTris, 3}, tri);
    f.write("/mesh/node_species", {kNodes}, std::vector<std::int32_t>{0, 0, 0, 0, 1, 1, 1, 1});
    for (std::size_t k = 0; k < frames; ++k) {
      std::vector<double> x(kNodes * 3, static_cast<double>(k)), ten(kTris, 0.5);
      const double t = 0.25 * static_cast<double>(k);
      f.append("/frames/positions", x.data(), {kNodes, 3});
      f.append("/frames/tension", ten.data(), {kTris});
      f.append("/frames/time", &t, {});
    }
  }
};

TEST(XdmfWriter, TimeSeriesIsWellFormedAndMatchesTheHdf5File) {
  TempDir dir;
  Fixture fx;
  const fs::path h5 = dir.path / "run.h5", xdmf = dir.path / "run.xdmf";
  XdmfWriter w(xdmf, fx.series());
  const std::vector<double> times = {0.0, 0.25, 0.5};
  for (std::size_t k = 0; k < times.size(); ++k) {
    fx.write_h5(h5, k + 1);
    w.add_frame(times[k]);
  }
  EXPECT_EQ(w.frame_count(), 3u);
  EXPECT_EQ(dir.entries(), (std::set<std::string>{"run.h5", "run.xdmf"}));  // no temporaries left

  const std::string text = slurp(xdmf);
  const auto doc = parse_xml(text);
  const Element& root = *doc->children[0];
  EXPECT_EQ(root.name, "Xdmf");
  const Element& series = root.child("Domain").child("Grid");
  EXPECT_EQ(series.attr("GridType"), "Collection");
  EXPECT_EQ(series.attr("CollectionType"), "Temporal");
  std::vector<const Element*> grids;
  for (const auto& g : series.children) grids.push_back(g.get());
  ASSERT_EQ(grids.size(), times.size());

  const auto h5f = H5File::open(h5);
  for (std::size_t f = 0; f < grids.size(); ++f) {
    const Element& g = *grids[f];
    SCOPED_TRACE("frame " + std::to_string(f));
    EXPECT_EQ(g.attr("GridType"), "Uniform");
    EXPECT_EQ(std::stod(g.child("Time").attr("Value")), times[f]);

    const Element& topo = g.child("Topology");
    EXPECT_EQ(topo.attr("TopologyType"), "Triangle");
    EXPECT_EQ(topo.attr("NumberOfElements"), "8");
    const Element& tri = topo.child("DataItem");
    const auto [tri_file, tri_path] = split_heavy(tri.text);
    EXPECT_EQ(tri_file, "run.h5");
    EXPECT_EQ(numbers(tri.attr("Dimensions")), h5f.dims(tri_path));

    const Element& geo = g.child("Geometry");
    EXPECT_EQ(geo.attr("GeometryType"), "XYZ");
    const Element& slab = geo.child("DataItem");
    EXPECT_EQ(slab.attr("ItemType"), "HyperSlab");
    EXPECT_EQ(numbers(slab.attr("Dimensions")), (std::vector<std::size_t>{1, 8, 3}));
    ASSERT_EQ(slab.children.size(), 2u);
    const Element& sel = *slab.children[0];
    EXPECT_EQ(numbers(sel.attr("Dimensions")), (std::vector<std::size_t>{3, 3}));
    EXPECT_EQ(numbers(sel.text), (std::vector<std::size_t>{f, 0, 0, 1, 1, 1, 1, 8, 3}));
    const Element& src = *slab.children[1];
    const auto [pos_file, pos_path] = split_heavy(src.text);
    EXPECT_EQ(pos_file, "run.h5");  // relative: file name only
    EXPECT_EQ(pos_path, "/frames/positions");
    EXPECT_EQ(numbers(src.attr("Dimensions")), h5f.dims(pos_path));
    EXPECT_EQ(src.attr("NumberType"), "Float");
    EXPECT_EQ(src.attr("Precision"), "8");

    const auto attrs = g.all("Attribute");
    ASSERT_EQ(attrs.size(), 2u);
    EXPECT_EQ(attrs[0]->attr("Name"), "species");
    EXPECT_EQ(attrs[0]->attr("Center"), "Node");
    EXPECT_EQ(numbers(attrs[0]->child("DataItem").attr("Dimensions")), h5f.dims("/mesh/node_species"));
    EXPECT_EQ(attrs[1]->attr("Center"), "Cell");
    const Element& tslab = attrs[1]->child("DataItem");
    EXPECT_EQ(tslab.attr("ItemType"), "HyperSlab");
    EXPECT_EQ(numbers(tslab.children.at(0)->text), (std::vector<std::size_t>{f, 0, 1, 1, 1, 8}));
    EXPECT_EQ(numbers(tslab.children.at(1)->attr("Dimensions")), h5f.dims("/frames/tension"));
  }
  if (have_xmllint()) {
    EXPECT_EQ(std::system(("xmllint --noout '" + xdmf.string() + "'").c_str()), 0) << text;
  }
}

TEST(XdmfWriter, RestartReplacesFrameTimes) {
  TempDir dir;
  Fixture fx;
  const fs::path xdmf = dir.path / "run.xdmf";
  XdmfWriter w(xdmf, fx.series());
  for (double t : {0.0, 1.0, 2.0, 3.0}) w.add_frame(t);
  w.set_frame_times({0.0, 1.0});
  const auto doc = parse_xml(slurp(xdmf));
  const auto grids = doc->all("Grid");
  ASSERT_EQ(grids.size(), 3u);  // collection + 2 frames
  const auto slabs = doc->all("DataItem");
  // Every HDF reference declares the current frame count (2) as its first dimension.
  for (const Element* d : slabs)
    if (d->text.find("/frames/positions") != std::string::npos) {
      EXPECT_EQ(numbers(d->attr("Dimensions"))[0], 2u);
    }
  // Empty series: still a valid document.
  w.set_frame_times({});
  const auto empty = parse_xml(slurp(xdmf));
  EXPECT_EQ(empty->all("Grid").size(), 1u);
}

TEST(XdmfWriter, NamesAreEscapedAndTimesExact) {
  TempDir dir;
  Fixture fx;
  XdmfSeries s = fx.series();
  s.grid_name = "a<b & \"c\"";
  s.attributes[0].name = "species>0";
  const double t = 0.1 + 0.2;  // needs 17 digits
  write_xdmf(dir.path / "e.xdmf", s, {t});
  const auto doc = parse_xml(slurp(dir.path / "e.xdmf"));
  EXPECT_EQ(doc->all("Grid")[0]->attr("Name"), "a<b & \"c\"");
  EXPECT_EQ(doc->all("Attribute")[0]->attr("Name"), "species>0");
  EXPECT_EQ(std::stod(doc->all("Time")[0]->attr("Value")), t);
  if (have_xmllint()) {
    EXPECT_EQ(std::system(("xmllint --noout '" + (dir.path / "e.xdmf").string() + "'").c_str()), 0);
  }
}

TEST(XdmfWriter, InconsistentDescriptionsAreRejected) {
  Fixture fx;
  auto expect_bad = [&](auto mutate) {
    XdmfSeries s = fx.series();
    mutate(s);
    EXPECT_THROW(validate(s), std::invalid_argument);
  };
  EXPECT_NO_THROW(validate(fx.series()));
  expect_bad([](XdmfSeries& s) { s.h5_file_name = "out/run.h5"; });  // must be relative: file name only
  expect_bad([](XdmfSeries& s) { s.h5_file_name = ""; });
  expect_bad([](XdmfSeries& s) { s.triangles.dims = {8, 4}; });
  expect_bad([](XdmfSeries& s) { s.triangles.number = XdmfNumber::Float64; });
  expect_bad([](XdmfSeries& s) { s.n_nodes = 0; });
  expect_bad([](XdmfSeries& s) { s.positions_path = "frames/positions"; });
  expect_bad([](XdmfSeries& s) { s.attributes[0].data.dims = {7}; });  // not one value per node
  expect_bad([](XdmfSeries& s) { s.attributes[1].data.dims = {8, 2}; });
  TempDir dir;
  XdmfSeries bad = fx.series();
  bad.n_nodes = 0;
  EXPECT_THROW(XdmfWriter(dir.path / "x.xdmf", bad), std::invalid_argument);
  EXPECT_TRUE(dir.entries().empty());
}

// With walls: every frame is a spatial collection (time on it) of the capsules, the two walls and the box, all three
// XDMF readers of ParaView 5.11 open it as one multiblock per time step (tests/paraview/check_xdmf.py). The walls are
// the planes y = 0 and y = H over the box, the box's 12 edges run along the axes with the box's side lengths.
TEST(XdmfWriter, WallsAndBoxAreAStaticGridInEveryFrame) {
  TempDir dir;
  Fixture fx;
  XdmfSeries s = fx.series();
  const double Lx = 10.155, H = 6.5, Lz = 0.1 + 0.2;  // Lz needs 17 digits
  s.walls = XdmfBox{Lx, H, Lz};
  s.frame_view = [](const std::string& p, std::size_t f) { return "/xdmf" + p.substr(p.rfind('/')) + "/" + std::to_string(f); };
  write_xdmf(dir.path / "w.xdmf", s, {0.0, 0.5});
  const auto doc = parse_xml(slurp(dir.path / "w.xdmf"));
  const Element& series = doc->children[0]->child("Domain").child("Grid");
  EXPECT_EQ(series.attr("CollectionType"), "Temporal");
  ASSERT_EQ(series.children.size(), 2u);
  for (std::size_t f = 0; f < 2; ++f) {
    SCOPED_TRACE("frame " + std::to_string(f));
    const Element& frame = *series.children[f];
    EXPECT_EQ(frame.attr("GridType"), "Collection");
    EXPECT_EQ(frame.attr("CollectionType"), "Spatial");
    EXPECT_EQ(std::stod(frame.child("Time").attr("Value")), 0.5 * static_cast<double>(f));
    std::vector<const Element*> grids;
    for (const auto& c : frame.children)
      if (c->name == "Grid") grids.push_back(c.get());
    ASSERT_EQ(grids.size(), 3u);
    EXPECT_EQ(grids[0]->attr("Name"), "capsules");
    EXPECT_EQ(grids[0]->child("Topology").attr("TopologyType"), "Triangle");
    EXPECT_EQ(grids[0]->all("Attribute").size(), 2u);
    EXPECT_THROW(grids[0]->child("Time"), std::runtime_error);  // the time is the collection's
    // Corner coordinates, read back from the inline XML.
    auto corners = [](const Element& g) {
      const Element& d = g.child("Geometry").child("DataItem");
      EXPECT_EQ(d.attr("Format"), "XML");
      EXPECT_EQ(numbers(d.attr("Dimensions")), (std::vector<std::size_t>{8, 3}));
      std::istringstream is(d.text);
      std::vector<std::array<double, 3>> p(8);
      for (auto& c : p) is >> c[0] >> c[1] >> c[2];
      EXPECT_FALSE(is.fail());
      return p;
    };
    auto cells = [](const Element& g) {
      const Element& d = g.child("Topology").child("DataItem");
      EXPECT_EQ(d.attr("Format"), "XML");
      return numbers(d.text);
    };
    const Element& walls = *grids[1];
    EXPECT_EQ(walls.attr("Name"), "walls");
    EXPECT_EQ(walls.child("Topology").attr("TopologyType"), "Quadrilateral");
    const auto wp = corners(walls);
    const auto wq = cells(walls);
    ASSERT_EQ(wq.size(), 8u);
    std::set<double> wall_heights;
    for (int q = 0; q < 2; ++q) {
      std::set<double> xs, ys, zs;
      for (int k = 0; k < 4; ++k) {
        const auto& c = wp.at(wq[4 * q + k]);
        xs.insert(c[0]);
        ys.insert(c[1]);
        zs.insert(c[2]);
      }
      EXPECT_EQ(ys.size(), 1u);  // a plane y = const
      wall_heights.insert(*ys.begin());
      EXPECT_EQ(xs, (std::set<double>{0.0, Lx}));  // spanning the box exactly
      EXPECT_EQ(zs, (std::set<double>{0.0, Lz}));
    }
    EXPECT_EQ(wall_heights, (std::set<double>{0.0, H}));
    const Element& box = *grids[2];
    EXPECT_EQ(box.attr("Name"), "box");
    EXPECT_EQ(box.child("Topology").attr("TopologyType"), "Polyline");
    EXPECT_EQ(box.child("Topology").attr("NodesPerElement"), "2");
    const auto bp = corners(box);
    const auto be = cells(box);
    ASSERT_EQ(be.size(), 24u);
    std::set<std::pair<std::size_t, std::size_t>> edges;
    std::map<double, int> lengths;
    for (int e = 0; e < 12; ++e) {
      const auto &p = bp.at(be[2 * e]), &q = bp.at(be[2 * e + 1]);
      int differ = 0;
      for (int d = 0; d < 3; ++d) differ += p[d] != q[d];
      EXPECT_EQ(differ, 1) << "edge " << e << " runs along an axis";
      ++lengths[std::abs(p[0] - q[0]) + std::abs(p[1] - q[1]) + std::abs(p[2] - q[2])];
      edges.insert(std::minmax(be[2 * e], be[2 * e + 1]));
    }
    EXPECT_EQ(edges.size(), 12u);
    EXPECT_EQ(lengths, (std::map<double, int>{{Lx, 4}, {H, 4}, {Lz, 4}}));
  }
  if (have_xmllint()) {
    EXPECT_EQ(std::system(("xmllint --noout '" + (dir.path / "w.xdmf").string() + "'").c_str()), 0);
  }
  s.walls = XdmfBox{Lx, 0.0, Lz};
  EXPECT_THROW(validate(s), std::invalid_argument);
}

}  // namespace
}  // namespace capsflow::test
