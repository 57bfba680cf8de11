// `capsflow figures` end to end: a synthetic analysis directory in the layout of `capsflow analyze` (written here
// with H5File: a set with X_f = 0, 0.5, 1, pair groups, isolated curves, and a second set at another 2a/H),
// the capsflow executable (env CAPSFLOW_BINARY) run on it, and the files it writes.
//
// Drawing needs python3 with numpy, matplotlib and h5py (Debian: python3-matplotlib python3-h5py, installed by
// tools/deps.sh); tests that draw are skipped with the reason when it is missing. The input checks made before
// python runs (a directory without analysis.h5, a file of another format) are tested everywhere.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "host/cli/figures_command.hpp"
#include "host/base/h5_file.hpp"
#include "host/state/icosphere.hpp"
#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using capsflow::H5File;
using capsflow::test::slurp;
using capsflow::test::TempDir;

#ifndef CAPSFLOW_TEST_DEFAULT_BINARY
#define CAPSFLOW_TEST_DEFAULT_BINARY nullptr
#endif

std::string capsflow_binary() {
  const char* v = std::getenv("CAPSFLOW_BINARY");
  if (v && *v) return v;
  return CAPSFLOW_TEST_DEFAULT_BINARY ? CAPSFLOW_TEST_DEFAULT_BINARY : "";
}

const double kNaN = std::nan("");
constexpr std::size_t kBins = 5;
const char* kSetA = "H=10.155 Lx=10.155 Lz=10.155 Np=50 Ca=0.2/0.5";
const char* kSetB = "H=6.6667 Lx=12.533 Lz=12.533 Np=50 Ca=0.2/0.5";

std::vector<double> bins_y() {
  std::vector<double> y(kBins);
  for (std::size_t k = 0; k < kBins; ++k) y[k] = (static_cast<double>(k) + 0.5) / (2.0 * kBins);
  return y;
}

std::vector<double> filled(std::size_t n, double v) { return std::vector<double>(n, v); }

void write_root(H5File& f, const std::string& format = "capsflow-analysis") {
  f.set_attribute("/", "capsflow_version", "test");
  f.set_attribute("/", "format", format);
  f.set_attribute("/", "format_version", 1);
  f.set_attribute("/", "bins", static_cast<int>(kBins));
}

void write_curve(H5File& f, const std::string& path, const std::string& set, double H) {
  f.create_group(path);
  f.set_attribute(path, "set", set);
  f.set_attribute(path, "ca_stiff", 0.2);
  f.set_attribute(path, "ca_floppy", 0.5);
  f.set_attribute(path, "H", H);
  f.set_attribute(path, "phi", 0.2);
  f.set_attribute(path, "two_a_over_H", 2.0 / H);
  const double shift = H < 8 ? -0.03 : 0.0;
  f.write(path + "/x_f", {3}, std::vector<double>{0.0, 0.5, 1.0});
  f.write(path + "/dbar_stiff", {3}, std::vector<double>{0.30 + shift, 0.34 + shift, kNaN});
  f.write(path + "/dbar_floppy", {3}, std::vector<double>{kNaN, 0.33 + shift, 0.31 + shift});
  f.write(path + "/dbar_all", {3}, std::vector<double>{0.30 + shift, 0.335 + shift, 0.31 + shift});
  f.write(path + "/E_s", {3}, std::vector<double>{kNaN, 1.2, kNaN});
  f.write(path + "/E_f", {3}, std::vector<double>{kNaN, 1.1, kNaN});
  for (const char* q : {"dbar_stiff", "dbar_floppy", "dbar_all", "E_s", "E_f"})
    f.write(path + "/" + q + "_se", {3}, filled(3, 0.01));
  // No fab_stiff / fab_floppy: the windows are shorter than the f_AB horizon of 100 strain units.
}

// A suspension group of set A: every dataset of the layout for the species present.
void write_suspension(H5File& f, const std::string& g, double xf) {
  const double H = 10.155;
  f.create_group(g);
  f.set_attribute(g, "key", "A xf=" + std::to_string(xf));
  f.set_attribute(g, "label", "A Xf=" + std::to_string(xf));
  f.set_attribute(g, "kind", "suspension");
  f.set_attribute(g, "x_f", xf);
  f.set_attribute(g, "H", H);
  f.set_attribute(g, "Lx", H);
  f.set_attribute(g, "Lz", H);
  f.set_attribute(g, "ca_stiff", 0.2);
  f.set_attribute(g, "ca_floppy", 0.5);
  f.set_attribute(g, "t0", 0.0);
  f.set_attribute(g, "t1", 50.0);
  f.set_attribute(g, "set", kSetA);
  f.set_attribute(g, "runs", "runs/a1.h5,runs/a2.h5");

  const bool stiff = xf < 1.0, floppy = xf > 0.0;
  const std::size_t T = 6;
  std::vector<double> t(T), d(T);
  for (std::size_t i = 0; i < T; ++i) {
    t[i] = 10.0 * static_cast<double>(i);
    d[i] = 0.4 - 0.01 * static_cast<double>(i);
  }
  f.write(g + "/dbar_t/time", {T}, t);
  f.write(g + "/dbar_t/stiff", {T}, stiff ? d : filled(T, kNaN));
  f.write(g + "/dbar_t/floppy", {T}, floppy ? d : filled(T, kNaN));
  f.write(g + "/dbar_t/all", {T}, d);

  f.write(g + "/profiles/y_over_H", {kBins}, bins_y());
  const std::vector<double> prof = {0.0, 1.5, 0.8, 1.0, 1.7};
  const std::vector<double> vel = {kNaN, 0.01, 0.006, 0.003, 0.0005};
  for (const char* sp : {"stiff", "floppy"}) {
    if ((std::string(sp) == "stiff" && !stiff) || (std::string(sp) == "floppy" && !floppy)) continue;
    const std::string s(sp);
    const std::vector<std::pair<std::string, std::vector<double>>> quantities = {
        {"n_hat", prof}, {"phi_hat", prof}, {"v_bar", vel}, {"v_prime", {kNaN, 0.02, 0.03, 0.025, 0.02}}};
    for (const auto& [q, v] : quantities) {
      f.write(g + "/profiles/" + q + "_" + s, {kBins}, v);
      f.write(g + "/profiles/" + q + "_" + s + "_se", {kBins}, filled(kBins, 0.01));
    }
    if (stiff && floppy) {
      f.write(g + "/profiles/dv_rel_" + s, {kBins}, std::vector<double>{kNaN, -0.1, -0.4, -0.2, kNaN});
      f.write(g + "/profiles/dv_rel_" + s + "_se", {kBins}, filled(kBins, 0.05));
    }
  }
  if (stiff && floppy) {
    f.write(g + "/profiles/xf_hat", {kBins}, std::vector<double>{kNaN, 0.7, 0.9, 1.1, 1.2});
    f.write(g + "/profiles/xf_hat_se", {kBins}, filled(kBins, 0.02));
  }
  if (!(stiff && floppy)) {  // P(v_p) of the pure species
    const std::string sp = stiff ? "stiff" : "floppy";
    for (int y0 : {200, 500}) {
      const std::string p = g + "/pdf/" + sp + "/y" + std::to_string(y0);
      const std::size_t nb = 10;
      std::vector<double> edges(nb + 1), density(nb);
      for (std::size_t i = 0; i <= nb; ++i) edges[i] = -0.1 + 0.02 * static_cast<double>(i);
      for (std::size_t i = 0; i < nb; ++i) {
        const double v = 0.5 * (edges[i] + edges[i + 1]);
        density[i] = i == 0 ? 0.0 : std::exp(-std::abs(v) / 0.03) / 0.06;  // an empty bin: left off the log plot
      }
      f.write(p + "/edges", {nb + 1}, edges);
      f.write(p + "/density", {nb}, density);
      f.set_attribute(p, "samples", 1000);
      f.set_attribute(p, "mean", 0.0);
      f.set_attribute(p, "stddev", 0.04);
    }
  }
  // Snapshot: two level-1 capsules, the first one stiff unless X_f = 1; one of them straddles x = Lx.
  const capsflow::TriMesh& m = capsflow::icosphere(1);
  const std::size_t nv = static_cast<std::size_t>(m.num_nodes()), nt = static_cast<std::size_t>(m.num_triangles());
  const double centres[2][3] = {{3.0, 2.5, 4.0}, {H - 0.3, 6.0, 5.0}};
  std::vector<double> pos;
  std::vector<std::int32_t> tri, species;
  for (std::size_t c = 0; c < 2; ++c) {
    for (std::size_t i = 0; i < nv; ++i) {
      pos.push_back(centres[c][0] + 1.1 * m.x[i]);
      pos.push_back(centres[c][1] + 0.9 * m.y[i]);
      pos.push_back(centres[c][2] + m.z[i]);
      species.push_back((c == 0 && stiff) || !floppy ? 1 : 0);
    }
    for (std::size_t k = 0; k < 3 * nt; ++k) tri.push_back(static_cast<std::int32_t>(m.tri[k] + c * nv));
  }
  f.write(g + "/snapshot/positions", {2 * nv, 3}, pos);
  f.write(g + "/snapshot/triangles", {2 * nt, 3}, tri);
  f.write(g + "/snapshot/node_species_stiff", {2 * nv}, species);  // int8 in analyze's files; any integer reads
  f.set_attribute(g + "/snapshot", "time", 50.0);
}

void write_pair(H5File& f, const std::string& g, double ca_top, double ca_bottom) {
  f.create_group(g);
  f.set_attribute(g, "kind", "pair");
  f.set_attribute(g, "label", "pair");
  f.set_attribute(g, "x_f", kNaN);
  f.set_attribute(g, "ca_top", ca_top);
  f.set_attribute(g, "ca_bottom", ca_bottom);
  const std::size_t T = 20;
  std::vector<double> t(T), sep(T), disp(T), uy(T);
  for (std::size_t i = 0; i < T; ++i) {
    t[i] = static_cast<double>(i);
    sep[i] = -10.0 + static_cast<double>(i);
    disp[i] = 0.2 * (1.0 + std::tanh((t[i] - 10.0) / 3.0));
    uy[i] = 0.2 / 3.0 / std::pow(std::cosh((t[i] - 10.0) / 3.0), 2);
  }
  f.write(g + "/time", {T}, t);
  f.write(g + "/separation", {T}, sep);
  f.write(g + "/disp_top", {T}, disp);
  f.write(g + "/disp_bottom", {T}, disp);
  f.write(g + "/uy_top", {T}, uy);
  f.write(g + "/uy_bottom", {T}, uy);
  f.set_attribute(g, "final_top", disp.back());
  f.set_attribute(g, "final_bottom", disp.back());
}

void write_isolated(H5File& f, double ca) {
  const std::string g = "/isolated/ca" + std::to_string(static_cast<int>(std::lround(1000 * ca)));
  f.create_group(g);
  f.set_attribute(g, "ca", ca);
  f.write(g + "/y_over_H", {3}, std::vector<double>{0.15, 0.3, 0.5});
  f.write(g + "/V_S", {3}, std::vector<double>{0.02 * (1 + ca), 0.01 * (1 + ca), 0.0});
}

// Set A with every kind of group; window 50 < 100, so no f_AB (figure 13 is skipped).
void write_set_a(const fs::path& dir) {
  fs::create_directories(dir);
  H5File f = H5File::create(dir / "analysis.h5");
  write_root(f);
  write_suspension(f, "/groups/g000", 0.0);
  write_suspension(f, "/groups/g001", 0.5);
  write_suspension(f, "/groups/g002", 1.0);
  write_pair(f, "/groups/g003", 0.2, 0.2);
  write_pair(f, "/groups/g004", 0.2, 0.5);
  write_curve(f, "/curves/c000", kSetA, 10.155);
  write_isolated(f, 0.2);
  write_isolated(f, 0.5);
  f.close();
}

// Only the curve of a set at 2a/H = 0.3 (as if set B were analysed on its own): figure 14 compares it with A.
void write_set_b(const fs::path& dir) {
  fs::create_directories(dir);
  H5File f = H5File::create(dir / "analysis.h5");
  write_root(f);
  write_curve(f, "/curves/c000", kSetB, 6.6667);
  f.close();
}

void write_root_only(const fs::path& dir, const std::string& format = "capsflow-analysis") {
  fs::create_directories(dir);
  H5File f = H5File::create(dir / "analysis.h5");
  write_root(f, format);
  f.close();
}

struct Result {
  int status = -1;
  std::string out, err;
};

bool is_png(const fs::path& p) {
  const std::string s = slurp(p);
  return s.size() > 8 && s.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0;
}

bool is_svg(const fs::path& p) {
  const std::string s = slurp(p);
  return s.size() > 100 && (s.rfind("<?xml", 0) == 0 || s.rfind("<svg", 0) == 0) &&
         s.find("</svg>") != std::string::npos;
}

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

class Figures : public testing::Test {
 protected:
  void SetUp() override {
    binary_ = capsflow_binary();
    if (binary_.empty()) GTEST_SKIP() << "CAPSFLOW_BINARY is not set";
  }

  // Skips the test when no python3 with numpy, matplotlib and h5py is found (the same search as capsflow's).
  bool python_missing() {
    const capsflow::FiguresPython py = capsflow::find_figures_python();
    if (py.python.empty()) {
      skip_reason_ = py.problem;
      return true;
    }
    return false;
  }

  Result run(const std::string& args) const {
    const std::string cmd = "cd '" + dir_.path.string() + "' && '" + binary_ + "' " + args + " >'" +
                            (dir_.path / "stdout.txt").string() + "' 2>'" + (dir_.path / "stderr.txt").string() +
                            "'";
    const int raw = std::system(cmd.c_str());
    Result r;
    r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
    r.out = slurp(dir_.path / "stdout.txt");
    r.err = slurp(dir_.path / "stderr.txt");
    return r;
  }

  fs::path path(const std::string& name) const { return dir_.path / name; }

  std::vector<std::string> files_in(const std::string& name) const {
    std::vector<std::string> v;
    if (!fs::is_directory(path(name))) return v;
    for (const auto& e : fs::directory_iterator(path(name))) v.push_back(e.path().filename().string());
    return v;
  }

  std::string binary_;
  std::string skip_reason_;
  TempDir dir_;
};

// status 2 and exactly one line "capsflow: error: ..." holding every part.
void expect_input_error(const Result& r, std::initializer_list<std::string> parts) {
  EXPECT_EQ(r.status, 2) << r.out << r.err;
  EXPECT_EQ(r.err.rfind("capsflow: error: ", 0), 0u) << r.err;
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "not one line: " << r.err;
  for (const auto& p : parts) EXPECT_TRUE(contains(r.err, p)) << "'" << p << "' not in: " << r.err;
}

TEST_F(Figures, DrawsEveryFigureThatHasData) {
  if (python_missing()) GTEST_SKIP() << skip_reason_;
  write_set_a(path("A"));
  write_set_b(path("B"));
  const Result r = run("figures A B --out figs");
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  // No Python warnings or tracebacks (a first matplotlib run may say that it builds its font cache: allowed).
  for (const char* bad : {"Warning", "Traceback", "error", "failed"})
    EXPECT_FALSE(contains(r.err, bad)) << r.err;

  for (const char* name : {"fig02_snapshots", "fig03_dbar_t", "fig04_dbar_xf", "fig05_n_hat", "fig06_phi_hat",
                           "fig07_enrichment", "fig08_v_bar", "fig09_pdf", "fig10_v_prime", "fig11_pair_collisions",
                           "fig14_confinement"}) {
    EXPECT_TRUE(is_png(path("figs") / (std::string(name) + ".png"))) << name << "\n" << r.out;
    EXPECT_TRUE(is_svg(path("figs") / (std::string(name) + ".svg"))) << name << "\n" << r.out;
  }
  // No data: skipped with a one-line note each, and no file.
  EXPECT_TRUE(contains(r.out, "fig13_fab: skipped: no suspension groups with a window >= 100\n")) << r.out;
  EXPECT_TRUE(contains(r.out, "fig15_volume_fraction: skipped: ")) << r.out;
  EXPECT_TRUE(contains(r.out, "fig16_rigidity_ratio: skipped: ")) << r.out;
  for (const char* name : {"fig13_fab", "fig15_volume_fraction", "fig16_rigidity_ratio"})
    for (const char* ext : {".png", ".svg"}) EXPECT_FALSE(fs::exists(path("figs") / (name + std::string(ext))));
  EXPECT_TRUE(contains(r.out, "wrote 11 figures (22 files)")) << r.out;
  EXPECT_TRUE(contains(r.out, "the paper's set A")) << r.out;
  for (const std::string& n : files_in("figs")) EXPECT_NE(n[0], '.') << "temporary left behind: " << n;
  EXPECT_EQ(files_in("figs").size(), 22u);
}

TEST_F(Figures, NothingToDrawIsNotAnError) {
  if (python_missing()) GTEST_SKIP() << skip_reason_;
  write_root_only(path("empty"));
  const Result r = run("figures empty --out figs");
  EXPECT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_TRUE(contains(r.out, "fig02_snapshots: skipped: ")) << r.out;
  EXPECT_TRUE(contains(r.out, "fig11_pair_collisions: skipped: ")) << r.out;
  EXPECT_TRUE(contains(r.out, "wrote 0 figures")) << r.out;
  EXPECT_TRUE(files_in("figs").empty());
}

TEST_F(Figures, ExistingOutputNeedsForce) {
  if (python_missing()) GTEST_SKIP() << skip_reason_;
  write_set_b(path("B"));  // one curve only: figure 4 is drawn
  fs::create_directories(path("figs"));
  std::ofstream(path("figs") / "fig04_dbar_xf.png") << "keep";

  expect_input_error(run("figures B --out figs"), {"figs/fig04_dbar_xf.png", "already exists", "--force"});
  EXPECT_EQ(slurp(path("figs") / "fig04_dbar_xf.png"), "keep");
  EXPECT_EQ(files_in("figs").size(), 1u) << "something was written";

  const Result r = run("figures B --out figs --force");
  EXPECT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_TRUE(is_png(path("figs") / "fig04_dbar_xf.png"));
  EXPECT_TRUE(is_svg(path("figs") / "fig04_dbar_xf.svg"));
}

TEST_F(Figures, DirectoryWithoutAnalysisFile) {
  fs::create_directories(path("nothing"));
  expect_input_error(run("figures nothing --out figs"), {"nothing", "no analysis.h5"});
  expect_input_error(run("figures missing --out figs"), {"missing", "no such directory or file"});
  EXPECT_FALSE(fs::exists(path("figs")));
}

TEST_F(Figures, AnalysisFileOfAnotherFormat) {
  write_root_only(path("run"), "capsflow-run");
  expect_input_error(run("figures run --out figs"), {"run/analysis.h5", "capsflow-run", "capsflow-analysis"});
  fs::create_directories(path("text"));
  std::ofstream(path("text") / "analysis.h5") << "not hdf5\n";
  expect_input_error(run("figures text --out figs"), {"text/analysis.h5"});
  EXPECT_FALSE(fs::exists(path("figs")));
}

// A run output draws the run's diagnostics (tools/capsflow_figures.py; tests/python/test_run_diagnostics.py checks
// the panels); its checkpoint, an analysis.h5 given as a file and other HDF5 files are refused before python runs.
TEST_F(Figures, RunFilesDrawTheirDiagnosticsCheckpointsAreRefused) {
  fs::create_directories(path("r"));
  std::ofstream(path("r") / "c.toml")
      << "[domain]\nH = 6.0\nLx = 8.0\nLz = 8.0\n[flow]\ntype = \"shear\"\n[capsules]\nmesh_level = 1\n"
         "[[species]]\nname = \"a\"\nca = 0.2\n[[capsule]]\nspecies = \"a\"\ncenter = [4.0, 3.0, 4.0]\n"
         "[time]\nend = 0.3\n[output]\nfile = \"out.h5\"\nevery = 0.1\n";
  ASSERT_EQ(run("run r/c.toml --output r/out.h5 -q").status, 0);
  expect_input_error(run("figures r/out.checkpoint.h5 --out figs"), {"r/out.checkpoint.h5", "a checkpoint", "out.h5"});
  write_root_only(path("a"));
  expect_input_error(run("figures a/analysis.h5 --out figs"), {"a/analysis.h5", "give its directory"});
  std::ofstream(path("text.h5")) << "not hdf5\n";
  expect_input_error(run("figures text.h5 --out figs"), {"text.h5"});
  EXPECT_FALSE(fs::exists(path("figs")));
  if (python_missing()) GTEST_SKIP() << skip_reason_;
  const Result r = run("figures r/out.h5 --out figs");
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_TRUE(is_png(path("figs") / "out_run_diagnostics.png"));
  EXPECT_TRUE(is_svg(path("figs") / "out_run_diagnostics.svg"));
}

TEST_F(Figures, OutMustBeADirectoryAndIsRequired) {
  write_root_only(path("empty"));
  std::ofstream(path("file.txt")) << "x";
  expect_input_error(run("figures empty --out file.txt"), {"file.txt", "not a directory"});
  expect_input_error(run("figures empty"), {"--out"});
  EXPECT_EQ(slurp(path("file.txt")), "x");
}

}  // namespace
