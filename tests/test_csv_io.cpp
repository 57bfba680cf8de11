// CSV reading and atomic writing of the `green` command (csv_io.hpp).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "host/base/csv_io.hpp"
#include "host/base/errors.hpp"

namespace capsflow {
namespace {

namespace fs = std::filesystem;

// A fresh empty directory per test, removed afterwards.
class CsvIo : public testing::Test {
 protected:
  void SetUp() override {
    std::string templ = (fs::temp_directory_path() / "capsflow_csv_XXXXXX").string();
    ASSERT_NE(::mkdtemp(templ.data()), nullptr);
    dir_ = templ;
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& text) const {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }
  static std::string slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
  }
  std::size_t entries() const {
    std::size_t n = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_)) ++n;
    return n;
  }

  fs::path dir_;
};

// The InputError message of f(), or "" when it succeeds.
template <class F>
std::string error_of(F f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

void expect_message(const std::string& msg, const std::string& prefix, std::initializer_list<std::string> parts) {
  ASSERT_FALSE(msg.empty()) << "no error";
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  EXPECT_EQ(msg.rfind(prefix, 0), 0u) << "'" << prefix << "' does not start: " << msg;
  for (const auto& p : parts) EXPECT_NE(msg.find(p), std::string::npos) << "'" << p << "' not in: " << msg;
}

TEST_F(CsvIo, ReadsPointForces) {
  const auto p = read_point_forces_csv(write("s.csv", "x,y,z,fx,fy,fz\n1,2,3,4,5,6\n\n-1.5e-3, 0 ,7,0,0,-2\r\n"));
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p.x[0], 1.0);
  EXPECT_EQ(p.fz[0], 6.0);
  EXPECT_EQ(p.x[1], -1.5e-3);
  EXPECT_EQ(p.y[1], 0.0);
  EXPECT_EQ(p.fz[1], -2.0);
  EXPECT_EQ(p.line[0], 2u);
  EXPECT_EQ(p.line[1], 4u);  // blank line 3 skipped
}

TEST_F(CsvIo, ReadsTargetsWithoutTrailingNewline) {
  const auto t = read_targets_csv(write("t.csv", "x,y,z\n0.25,0.5,0.75"));
  ASSERT_EQ(t.size(), 1u);
  EXPECT_EQ(t.z[0], 0.75);
}

TEST_F(CsvIo, RoundTripAtFullPrecision) {
  TargetPoints t;
  const double vals[] = {0.1, 1.0 / 3.0, 2.0 / 3.0, 1e-300, 5e-324, -123456789.123456789, 3.0, 0.0};
  for (std::size_t i = 0; i < std::size(vals); ++i) {
    t.x.push_back(vals[i]);
    t.y.push_back(vals[(i + 1) % std::size(vals)]);
    t.z.push_back(-vals[(i + 2) % std::size(vals)]);
  }
  std::vector<double> ux(t.size()), uy(t.size()), uz(t.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    ux[i] = std::nextafter(vals[i], 1.0);
    uy[i] = std::sqrt(2.0) * static_cast<double>(i);
    uz[i] = -std::exp(-static_cast<double>(i));
  }
  const std::string out = (dir_ / "U.csv").string();
  write_velocities_csv(out, t, ux.data(), uy.data(), uz.data(), false);

  const std::string text = slurp(out);
  EXPECT_EQ(text.rfind("x,y,z,ux,uy,uz\n", 0), 0u);
  // The output reads back bit for bit (as a 6-column file through the point-force reader).
  const std::string as_forces = "x,y,z,fx,fy,fz\n" + text.substr(text.find('\n') + 1);
  const auto back = read_point_forces_csv(write("back.csv", as_forces));
  ASSERT_EQ(back.size(), t.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    EXPECT_EQ(back.x[i], t.x[i]);
    EXPECT_EQ(back.y[i], t.y[i]);
    EXPECT_EQ(back.z[i], t.z[i]);
    EXPECT_EQ(back.fx[i], ux[i]);
    EXPECT_EQ(back.fy[i], uy[i]);
    EXPECT_EQ(back.fz[i], uz[i]);
  }
  EXPECT_EQ(entries(), 2u);  // U.csv and back.csv: no temporary left behind
}

TEST_F(CsvIo, MissingFile) {
  const std::string path = (dir_ / "nope.csv").string();
  expect_message(error_of([&] { read_point_forces_csv(path); }), path + ":", {"cannot open"});
  expect_message(error_of([&] { read_targets_csv(path); }), path + ":", {"cannot open"});
}

TEST_F(CsvIo, EmptyFile) {
  const auto path = write("e.csv", "");
  expect_message(error_of([&] { read_targets_csv(path); }), path + ":", {"empty file", "x,y,z"});
  const auto blank = write("b.csv", "\n\n");
  expect_message(error_of([&] { read_point_forces_csv(blank); }), blank + ":", {"empty file"});
}

TEST_F(CsvIo, WrongHeader) {
  const auto a = write("a.csv", "x,y,z,fx,fy\n1,2,3,4,5\n");
  expect_message(error_of([&] { read_point_forces_csv(a); }), a + ":1:", {"x,y,z,fx,fy,fz", "'x,y,z,fx,fy'"});
  const auto b = write("b.csv", "1,2,3\n");
  expect_message(error_of([&] { read_targets_csv(b); }), b + ":1:", {"expected the header 'x,y,z'"});
  const auto c = write("c.csv", "x,z,y\n1,2,3\n");
  expect_message(error_of([&] { read_targets_csv(c); }), c + ":1:", {"header"});
}

TEST_F(CsvIo, WrongFieldCount) {
  const auto a = write("a.csv", "x,y,z,fx,fy,fz\n1,2,3,4,5,6\n1,2,3,4,5\n");
  expect_message(error_of([&] { read_point_forces_csv(a); }), a + ":3:", {"expected 6 fields", "got 5"});
  const auto b = write("b.csv", "x,y,z\n1,2,3,4\n");
  expect_message(error_of([&] { read_targets_csv(b); }), b + ":2:", {"expected 3 fields", "got 4"});
}

TEST_F(CsvIo, NonNumericOrNonFiniteField) {
  const auto a = write("a.csv", "x,y,z\n1,abc,3\n");
  expect_message(error_of([&] { read_targets_csv(a); }), a + ":2:", {"column 2 (y)", "finite number", "'abc'"});
  const auto b = write("b.csv", "x,y,z\n1,2,3x\n");
  expect_message(error_of([&] { read_targets_csv(b); }), b + ":2:", {"column 3 (z)", "'3x'"});
  const auto c = write("c.csv", "x,y,z,fx,fy,fz\n1,2,3,nan,0,0\n");
  expect_message(error_of([&] { read_point_forces_csv(c); }), c + ":2:", {"column 4 (fx)", "'nan'"});
  const auto d = write("d.csv", "x,y,z,fx,fy,fz\n1,2,3,0,inf,0\n");
  expect_message(error_of([&] { read_point_forces_csv(d); }), d + ":2:", {"(fy)", "'inf'"});
  const auto e = write("e.csv", "x,y,z\n1,,3\n");
  expect_message(error_of([&] { read_targets_csv(e); }), e + ":2:", {"empty field"});
  const auto f = write("f.csv", "x,y,z\n1e999,1,1\n");
  expect_message(error_of([&] { read_targets_csv(f); }), f + ":2:", {"(x)", "'1e999'"});
}

TEST_F(CsvIo, NoDataRows) {
  const auto a = write("a.csv", "x,y,z\n");
  expect_message(error_of([&] { read_targets_csv(a); }), a + ":", {"no data rows"});
  const auto b = write("b.csv", "x,y,z,fx,fy,fz\n\n");
  expect_message(error_of([&] { read_point_forces_csv(b); }), b + ":", {"no data rows"});
}

TEST_F(CsvIo, PointsOutsideTheSlit) {
  const auto s = read_point_forces_csv(write("s.csv", "x,y,z,fx,fy,fz\n0,0,0,1,1,1\n0,4,0,1,1,1\n0,4.5,0,1,1,1\n"));
  expect_message(error_of([&] { validate_in_slit(s, 4.0, "s.csv"); }), "s.csv:4:",
                 {"row 3", "0 <= y <= H = 4", "y = 4.5"});
  EXPECT_EQ(error_of([&] { validate_in_slit(s, 4.5, "s.csv"); }), "");  // walls included

  const auto t = read_targets_csv(write("t.csv", "x,y,z\n1,-1e-12,1\n"));
  expect_message(error_of([&] { validate_in_slit(t, 4.0, "t.csv"); }), "t.csv:2:", {"row 1", "y = -1e-12"});
}

TEST_F(CsvIo, ExistingOutputIsNotOverwritten) {
  const std::string out = write("U.csv", "precious\n");
  TargetPoints t;
  t.x = {1};
  t.y = {2};
  t.z = {3};
  const double u = 0.5;
  expect_message(error_of([&] { write_velocities_csv(out, t, &u, &u, &u, false); }), out + ":", {"already exists"});
  expect_message(error_of([&] { check_output_path(out, false); }), out + ":", {"already exists"});
  EXPECT_EQ(slurp(out), "precious\n");
  EXPECT_EQ(entries(), 1u);  // no temporary left behind

  EXPECT_EQ(error_of([&] { check_output_path(out, true); }), "");
  write_velocities_csv(out, t, &u, &u, &u, true);
  EXPECT_EQ(slurp(out), "x,y,z,ux,uy,uz\n1,2,3,0.5,0.5,0.5\n");
  EXPECT_EQ(entries(), 1u);
}

TEST_F(CsvIo, MissingOutputDirectory) {
  const std::string out = (dir_ / "no" / "U.csv").string();
  TargetPoints t;
  t.x = t.y = t.z = {1};
  const double u = 0.0;
  expect_message(error_of([&] { write_velocities_csv(out, t, &u, &u, &u, true); }), out + ":", {"does not exist"});
  EXPECT_EQ(entries(), 0u);
}

TEST_F(CsvIo, NewFileHasUsualPermissions) {
  const std::string out = (dir_ / "U.csv").string();
  TargetPoints t;
  t.x = t.y = t.z = {1};
  const double u = 0.0;
  write_velocities_csv(out, t, &u, &u, &u, false);
  const auto perms = fs::status(out).permissions();
  EXPECT_NE(perms & fs::perms::owner_read, fs::perms::none);
  EXPECT_NE(perms & fs::perms::owner_write, fs::perms::none);
}

}  // namespace
}  // namespace capsflow
