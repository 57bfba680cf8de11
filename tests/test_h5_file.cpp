// H5File: round trips of every type and rank, appends, truncation, strings, errors, checkpoints, RNG state
// and readability of a file that was flushed but never closed.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <numeric>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "host/base/errors.hpp"
#include "host/base/h5_file.hpp"
#include "support/temp_dir.hpp"

namespace capsflow::test {
namespace {

namespace fs = std::filesystem;



template <class T>
std::vector<T> ramp(std::size_t n, T offset) {
  std::vector<T> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<T>(static_cast<T>(i) * static_cast<T>(3) - offset);
  return v;
}

template <class T>
void round_trip_all_ranks(H5File& f, const std::string& prefix, T offset) {
  const std::vector<std::vector<std::size_t>> shapes = {{}, {7}, {3, 4}, {2, 3, 5}, {2, 1, 3, 2}, {0, 3}, {4, 0}};
  for (std::size_t k = 0; k < shapes.size(); ++k) {
    std::size_t n = 1;
    for (std::size_t d : shapes[k]) n *= d;
    const auto v = ramp<T>(n, offset);
    const std::string path = prefix + "/shape" + std::to_string(k);
    f.write(path, shapes[k], v);
    EXPECT_EQ(f.dims(path), shapes[k]);
  }
}

template <class T>
void check_all_ranks(const H5File& f, const std::string& prefix, T offset) {
  const std::vector<std::vector<std::size_t>> shapes = {{}, {7}, {3, 4}, {2, 3, 5}, {2, 1, 3, 2}, {0, 3}, {4, 0}};
  for (std::size_t k = 0; k < shapes.size(); ++k) {
    std::size_t n = 1;
    for (std::size_t d : shapes[k]) n *= d;
    const auto a = f.read<T>(prefix + "/shape" + std::to_string(k));
    EXPECT_EQ(a.dims, shapes[k]) << prefix << " shape " << k;
    EXPECT_EQ(a.data, ramp<T>(n, offset)) << prefix << " shape " << k;
  }
}

TEST(H5File, FixedDatasetsRoundTripEveryTypeAndRank) {
  TempDir dir;
  const fs::path p = dir.path / "fixed.h5";
  {
    auto f = H5File::create(p);
    round_trip_all_ranks<double>(f, "/f64", 0.25);
    round_trip_all_ranks<std::int32_t>(f, "/i32", 5);
    round_trip_all_ranks<std::int64_t>(f, "/i64", std::int64_t{1} << 40);
    f.close();
    EXPECT_FALSE(f.is_open());
  }
  const auto f = H5File::open(p);
  EXPECT_TRUE(f.read_only());
  check_all_ranks<double>(f, "/f64", 0.25);
  check_all_ranks<std::int32_t>(f, "/i32", 5);
  check_all_ranks<std::int64_t>(f, "/i64", std::int64_t{1} << 40);
  // Reading converts like HDF5 does: integers as doubles.
  const auto conv = f.read<double>("/i32/shape1");
  EXPECT_EQ(conv.data[2], 1.0);
}

TEST(H5File, DoublesRoundTripBitForBit) {
  TempDir dir;
  const fs::path p = dir.path / "bits.h5";
  std::vector<double> v = {0.0, -0.0, 1.0 / 3.0, std::numeric_limits<double>::denorm_min(),
                           std::numeric_limits<double>::max(), -std::numeric_limits<double>::infinity(),
                           std::numeric_limits<double>::quiet_NaN(), std::nextafter(1.0, 2.0)};
  std::uint64_t payload_nan = 0x7ff80000deadbeefULL;
  double d;
  std::memcpy(&d, &payload_nan, sizeof d);
  v.push_back(d);
  std::mt19937_64 rng(42);
  for (int i = 0; i < 1000; ++i) {
    const std::uint64_t bits = rng();
    std::memcpy(&d, &bits, sizeof d);
    if (!std::isnan(d)) v.push_back(d);  // arbitrary bit patterns (signalling NaNs may be quieted by the FPU)
  }
  {
    auto f = H5File::create(p);
    f.write("/state/x", {v.size()}, v);
    f.append("/state/series", v.data(), {v.size()});
  }
  const auto f = H5File::open(p);
  for (const char* path : {"/state/x", "/state/series"}) {
    const auto r = f.read<double>(path);
    ASSERT_EQ(r.data.size(), v.size()) << path;
    EXPECT_EQ(std::memcmp(r.data.data(), v.data(), v.size() * sizeof(double)), 0) << path;
  }
}

TEST(H5File, AttributesRoundTrip) {
  TempDir dir;
  const fs::path p = dir.path / "attrs.h5";
  {
    auto f = H5File::create(p);
    f.create_group("/series");
    f.write<double>("/series/x", {2}, std::vector<double>{1, 2});
    f.set_attribute("/", "dt", 1e-3);
    f.set_attribute("/", "steps", std::int64_t{1} << 50);
    f.set_attribute("/", "small_int", 7);
    f.set_attribute("/", "size", std::size_t{12});
    f.set_attribute("/", "flag", true);
    f.set_attribute("/", "version", "0.1.0");
    f.set_attribute("/", "empty", std::string());
    f.set_attribute("/series", "units", std::string("µm, s — UTF-8"));
    f.set_attribute("/series/x", "description", std::string_view("centroid x"));
    f.set_attribute("/", "replaced", 1.5);
    f.set_attribute("/", "replaced", "now a string");
    EXPECT_THROW(f.set_attribute("/", "nul", std::string("a\0b", 3)), std::invalid_argument);
    EXPECT_THROW(f.set_attribute("/nowhere", "x", 1.0), H5Error);
  }
  const auto f = H5File::open(p);
  EXPECT_EQ(f.attribute<double>("/", "dt"), 1e-3);
  EXPECT_EQ(f.attribute<std::int64_t>("/", "steps"), std::int64_t{1} << 50);
  EXPECT_EQ(f.attribute<std::int64_t>("/", "small_int"), 7);
  EXPECT_EQ(f.attribute<std::int64_t>("/", "size"), 12);
  EXPECT_EQ(f.attribute<std::int64_t>("/", "flag"), 1);
  EXPECT_EQ(f.attribute<double>("/", "small_int"), 7.0);
  EXPECT_EQ(f.attribute<std::string>("/", "version"), "0.1.0");
  EXPECT_EQ(f.attribute<std::string>("/", "empty"), "");
  EXPECT_EQ(f.attribute<std::string>("/series", "units"), "µm, s — UTF-8");
  EXPECT_EQ(f.attribute<std::string>("/series/x", "description"), "centroid x");
  EXPECT_EQ(f.attribute<std::string>("/", "replaced"), "now a string");
  EXPECT_TRUE(f.has_attribute("/", "dt"));
  EXPECT_FALSE(f.has_attribute("/", "nope"));
  EXPECT_THROW(f.attribute<double>("/", "version"), H5Error);
  EXPECT_THROW(f.attribute<std::string>("/", "dt"), H5Error);
  EXPECT_THROW(f.attribute<double>("/", "nope"), H5Error);
}

TEST(H5File, StringDatasetsAndGroups) {
  TempDir dir;
  const fs::path p = dir.path / "strings.h5";
  const std::string config = "# capsflow configuration\n[slit]\nheight = 10.0  # µm\n\n[run]\nsteps = 100\n";
  {
    auto f = H5File::create(p);
    f.write_string("/config/text", config);
    f.write_string("/config/empty", "");
    f.create_group("/a/b/c");
    f.create_group("/a/b/c");  // existing group: fine
    EXPECT_THROW(f.create_group("/config/text"), H5Error);
    EXPECT_THROW(f.write_string("/config/text", "again"), H5Error);
  }
  const auto f = H5File::open(p);
  EXPECT_EQ(f.read_string("/config/text"), config);
  EXPECT_EQ(f.read_string("/config/empty"), "");
  EXPECT_TRUE(f.exists("/"));
  EXPECT_TRUE(f.exists("/a/b/c"));
  EXPECT_TRUE(f.exists("/a/b"));
  EXPECT_FALSE(f.exists("/a/x/c"));
  EXPECT_FALSE(f.exists("/zzz"));
  EXPECT_THROW(f.read<double>("/config/text"), H5Error);
  EXPECT_THROW(f.read_string("/a/b"), H5Error);
}

TEST(H5File, AppendsAcrossReopen) {
  TempDir dir;
  const fs::path p = dir.path / "series.h5";
  const std::size_t np = 4;
  std::vector<double> all_t, all_c;
  std::vector<std::int64_t> all_steps;
  auto record = [&](H5File& f, int step) {
    const double t = 0.5 * step;
    std::vector<double> c(np * 3);
    for (std::size_t i = 0; i < c.size(); ++i) c[i] = step * 100.0 + static_cast<double>(i);
    const std::int64_t s = step;
    f.append("/series/time", &t, {});
    f.append("/series/centroid", c.data(), {np, 3});
    f.append("/series/step", &s, {});
    all_t.push_back(t);
    all_c.insert(all_c.end(), c.begin(), c.end());
    all_steps.push_back(s);
  };
  {
    auto f = H5File::create(p);
    for (int s = 0; s < 3; ++s) record(f, s);
    EXPECT_EQ(f.extent("/series/time"), 3u);
  }
  {
    auto f = H5File::open(p, H5Access::ReadWrite);
    EXPECT_FALSE(f.read_only());
    for (int s = 3; s < 5; ++s) record(f, s);
    // Several records at once.
    const std::vector<double> two = {10.0, 11.0};
    f.append("/series/time", two.data(), {}, 2);
    all_t.insert(all_t.end(), two.begin(), two.end());
  }
  const auto f = H5File::open(p);
  const auto t = f.read<double>("/series/time");
  EXPECT_EQ(t.dims, (std::vector<std::size_t>{7}));
  EXPECT_EQ(t.data, all_t);
  const auto c = f.read<double>("/series/centroid");
  EXPECT_EQ(c.dims, (std::vector<std::size_t>{5, np, 3}));
  EXPECT_EQ(c.data, all_c);
  const auto s = f.read<std::int64_t>("/series/step");
  EXPECT_EQ(s.data, all_steps);
  const auto mid = f.read_records<double>("/series/centroid", 1, 2);
  EXPECT_EQ(mid.dims, (std::vector<std::size_t>{2, np, 3}));
  EXPECT_EQ(mid.data, std::vector<double>(all_c.begin() + np * 3, all_c.begin() + 3 * np * 3));
  EXPECT_THROW(f.read_records<double>("/series/centroid", 4, 2), std::out_of_range);
}

TEST(H5File, AppendRejectsMismatchedRecords) {
  TempDir dir;
  auto f = H5File::create(dir.path / "mismatch.h5");
  const std::vector<double> x(12, 1.0);
  f.append("/frames/positions", x.data(), {4, 3});
  EXPECT_THROW(f.append("/frames/positions", x.data(), {3, 4}), H5Error);
  EXPECT_THROW(f.append("/frames/positions", x.data(), {12}), H5Error);
  const std::int32_t i = 1;
  EXPECT_THROW(f.append("/frames/positions", &i, {4, 3}), H5Error);
  f.write("/fixed", {12}, x);
  EXPECT_THROW(f.append("/fixed", x.data(), {}), H5Error);
  EXPECT_THROW(f.truncate("/fixed", 1), H5Error);
  EXPECT_THROW(f.create_extendable<double>("/zero", {0, 3}), std::invalid_argument);
  EXPECT_EQ(f.extent("/frames/positions"), 1u);
}

// Compression: shuffle + deflate on the extendable datasets made after set_compression, lossless for any bit pattern,
// across truncate, reopen and append; fixed datasets and level 0 stay unfiltered; a level outside 0..9 is refused.
TEST(H5File, CompressedExtendableDatasetsStayBitExactThroughTruncateAndAppend) {
  TempDir dir;
  const fs::path p = dir.path / "deflate.h5";
  std::mt19937_64 rng(7);
  std::vector<double> v(3 * 500);
  for (double& d : v) {
    do {
      const std::uint64_t bits = rng();
      std::memcpy(&d, &bits, sizeof d);
    } while (std::isnan(d));
  }
  {
    auto f = H5File::create(p);
    EXPECT_EQ(f.compression(), 0);
    EXPECT_THROW(f.set_compression(10), std::invalid_argument);
    EXPECT_THROW(f.set_compression(-1), std::invalid_argument);
    f.append("/plain/x", v.data(), {500, 3});
    f.set_compression(6);
    for (int k = 0; k < 4; ++k) f.append("/deflated/x", v.data(), {500, 3});
    f.write("/fixed", {v.size()}, v);
    EXPECT_EQ(f.filters("/deflated/x"), (std::vector<std::string>{"shuffle", "deflate"}));
    EXPECT_TRUE(f.filters("/plain/x").empty());
    EXPECT_TRUE(f.filters("/fixed").empty());
    EXPECT_EQ(f.datasets(), (std::vector<std::string>{"/deflated/x", "/fixed", "/plain/x"}));
    EXPECT_EQ(f.datasets("/plain"), (std::vector<std::string>{"/plain/x"}));
  }
  {
    auto f = H5File::open(p, H5Access::ReadWrite);
    f.truncate("/deflated/x", 1);
    std::vector<double> w(v.rbegin(), v.rend());
    f.append("/deflated/x", w.data(), {500, 3});
  }
  const auto f = H5File::open(p);
  const auto r = f.read<double>("/deflated/x");
  ASSERT_EQ(r.dims, (std::vector<std::size_t>{2, 500, 3}));
  EXPECT_EQ(std::memcmp(r.data.data(), v.data(), 8 * v.size()), 0);
  std::vector<double> w(v.rbegin(), v.rend());
  EXPECT_EQ(std::memcmp(r.data.data() + v.size(), w.data(), 8 * w.size()), 0);
}

// The records per chunk of an extendable dataset, read with the HDF5 C API.
hsize_t records_per_chunk(const fs::path& file, const char* dataset) {
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t d = H5Dopen2(f, dataset, H5P_DEFAULT);
  const hid_t p = H5Dget_create_plist(d);
  hsize_t dims[8] = {0};
  const int rank = H5Pget_chunk(p, 8, dims);
  H5Pclose(p);
  H5Dclose(d);
  H5Fclose(f);
  return rank > 0 ? dims[0] : 0;
}

// A compressed chunk is written whole at a new place whenever it changes, so a kill during the write can tear the
// records it already held: compressed datasets take one record per chunk (written once), plain ones many.
TEST(H5File, CompressedDatasetsHoldOneRecordPerChunk) {
  TempDir dir;
  const fs::path p = dir.path / "chunks.h5";
  const std::vector<double> v(30, 1.5);
  {
    auto f = H5File::create(p);
    f.append("/plain", v.data(), {30});
    f.set_compression(4);
    f.append("/deflated", v.data(), {30});
    f.create_extendable<double>("/deflated_asked_for_8", {30}, 8);
  }
  EXPECT_EQ(records_per_chunk(p, "/plain"), 65536u / 240u);
  EXPECT_EQ(records_per_chunk(p, "/deflated"), 1u);
  EXPECT_EQ(records_per_chunk(p, "/deflated_asked_for_8"), 1u);
}

// A finished output's series are copied into a new file re-chunked and compressed (copy_dataset_rechunked): any bit
// pattern, every element type, the maximum shape, chunks of many records, the attributes (strings, integers, doubles)
// and a copy back to plain chunks that grows again like the original.
TEST(H5File, RechunkedCopiesKeepEveryBitAndAttribute) {
  TempDir dir;
  std::mt19937_64 rng(11);
  std::vector<double> v(3 * 1000);
  for (double& d : v) {
    const std::uint64_t bits = rng();
    std::memcpy(&d, &bits, sizeof d);  // NaN payloads included: the bytes go across unconverted
  }
  std::vector<std::int64_t> n(1000);
  std::iota(n.begin(), n.end(), -7);
  const std::vector<float> g = {1.0f / 3.0f, -0.0f, 3.4e38f, 1e-45f};
  {
    auto f = H5File::create(dir.path / "src.h5");
    f.append("/series/x", v.data(), {3}, 1000);
    f.append("/series/n", n.data(), {}, 1000);
    f.append("/series/g", g.data(), {2}, 2);
    f.create_extendable<std::int32_t>("/series/empty", {2});
    f.set_attribute("/series/x", "units", "a");
    f.set_attribute("/series/x", "bins", 50);
    f.set_attribute("/series/x", "scale", 0.25);
    f.set_attribute("/series", "note", "group attribute");
  }
  {
    const auto src = H5File::open(dir.path / "src.h5");
    auto dst = H5File::create(dir.path / "dst.h5");
    dst.create_group("/series");
    src.copy_attributes("/series", dst, "/series");
    for (const char* p : {"/series/x", "/series/n", "/series/g", "/series/empty"}) src.copy_dataset_rechunked(p, dst, 4);
    EXPECT_THROW(src.copy_dataset_rechunked("/series/x", dst, 10), std::invalid_argument);
  }
  EXPECT_EQ(records_per_chunk(dir.path / "dst.h5", "/series/x"), 65536u / 24u);
  const auto dst = H5File::open(dir.path / "dst.h5");
  const auto x = dst.read<double>("/series/x");
  ASSERT_EQ(x.dims, (std::vector<std::size_t>{1000, 3}));
  EXPECT_EQ(std::memcmp(x.data.data(), v.data(), 8 * v.size()), 0);
  EXPECT_EQ(dst.read<std::int64_t>("/series/n").data, n);
  const auto gr = dst.read<float>("/series/g");
  EXPECT_EQ(std::memcmp(gr.data.data(), g.data(), 4 * g.size()), 0);
  EXPECT_EQ(dst.dims("/series/empty"), (std::vector<std::size_t>{0, 2}));
  for (const char* p : {"/series/x", "/series/n", "/series/g", "/series/empty"})
    EXPECT_EQ(dst.filters(p), (std::vector<std::string>{"shuffle", "deflate"})) << p;
  EXPECT_EQ(dst.attribute<std::string>("/series/x", "units"), "a");
  EXPECT_EQ(dst.attribute<std::int64_t>("/series/x", "bins"), 50);
  EXPECT_EQ(dst.attribute<double>("/series/x", "scale"), 0.25);
  EXPECT_EQ(dst.attribute<std::string>("/series", "note"), "group attribute");

  // Back to plain chunks (a restart continuing a finished output): it grows as the original did.
  {
    auto plain = H5File::create(dir.path / "plain.h5");
    plain.create_group("/series");
    dst.copy_dataset_rechunked("/series/x", plain, 0);
    EXPECT_TRUE(plain.filters("/series/x").empty());
    plain.append("/series/x", v.data(), {3}, 2);
  }
  EXPECT_EQ(records_per_chunk(dir.path / "plain.h5", "/series/x"), records_per_chunk(dir.path / "src.h5", "/series/x"));
  const auto grown = H5File::open(dir.path / "plain.h5").read<double>("/series/x");
  ASSERT_EQ(grown.dims, (std::vector<std::size_t>{1002, 3}));
  EXPECT_EQ(std::memcmp(grown.data.data() + 3000, v.data(), 8 * 6), 0);
}

// copy_object copies object by object (not H5Ocopy, which crashes on a write error: issue 55): every group, dataset,
// attribute and link arrives with its content bit for bit and its creation properties (chunks, filters, maximum shape,
// fill value), compressed chunks as stored, a chunk never written still unwritten, a second hard link still one object.
TEST(H5File, CopiedObjectsKeepEveryBitAndCreationProperty) {
  TempDir dir;
  std::mt19937_64 rng(5);
  std::vector<double> v(4 * 9);
  for (double& d : v) {
    const std::uint64_t bits = rng();
    std::memcpy(&d, &bits, sizeof d);
  }
  const std::vector<std::int32_t> tri = {0, 1, 2, 2, 1, 3};
  {
    auto f = H5File::create(dir.path / "src.h5");
    f.set_compression(4);
    f.append("/frames/positions", v.data(), {3, 3}, 4);  // one record per compressed chunk
    f.set_compression(0);
    f.append("/series/time", v.data(), {}, 7);
    f.truncate("/series/time", 5);
    f.write("/mesh/triangles", {2, 3}, tri);
    f.write("/mesh/empty", {0, 3}, std::vector<double>{});
    f.write_string("/config/text", "a = 1\nb = \"\u00e9\"\n");
    f.set_attribute("/frames/positions", "units", "a");
    f.set_attribute("/mesh", "level", 1);
    f.set_attribute("/", "run_id", "x");
    f.create_record_view("/xdmf/positions/2", "/frames/positions", 2, {3, 3});
  }
  {
    // Through the C API: what H5File does not make (a partly written chunked dataset with a fill value, links).
    const hid_t file = H5Fopen((dir.path / "src.h5").c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(file, 0);
    const hsize_t dims[2] = {10, 4}, maxdims[2] = {H5S_UNLIMITED, 4}, chunk[2] = {3, 2};
    const hid_t space = H5Screate_simple(2, dims, maxdims);
    const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(dcpl, 2, chunk);
    const double fill = -2.5;
    H5Pset_fill_value(dcpl, H5T_NATIVE_DOUBLE, &fill);
    const hid_t d = H5Dcreate2(file, "/mesh/sparse", H5T_IEEE_F64LE, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    const hsize_t start[2] = {3, 2}, count[2] = {3, 2};  // one whole chunk written, the others never
    H5Sselect_hyperslab(space, H5S_SELECT_SET, start, nullptr, count, nullptr);
    const hid_t mem = H5Screate_simple(2, count, nullptr);
    EXPECT_GE(H5Dwrite(d, H5T_NATIVE_DOUBLE, mem, space, H5P_DEFAULT, v.data()), 0);
    H5Sclose(mem);
    H5Dclose(d);
    H5Pclose(dcpl);
    H5Sclose(space);
    EXPECT_GE(H5Lcreate_soft("/mesh/triangles", file, "/mesh/alias", H5P_DEFAULT, H5P_DEFAULT), 0);
    EXPECT_GE(H5Lcreate_hard(file, "/mesh/triangles", file, "/mesh/same", H5P_DEFAULT, H5P_DEFAULT), 0);
    H5Fclose(file);
  }
  {
    const auto src = H5File::open(dir.path / "src.h5");
    auto dst = H5File::create(dir.path / "dst.h5");
    src.copy_attributes("/", dst, "/");
    for (const char* g : {"/frames", "/series", "/mesh", "/config", "/xdmf"}) src.copy_object(g, dst);
    EXPECT_THROW(src.copy_object("/mesh", dst), H5Error);  // exists there already
  }
  {
    const auto a = H5File::open(dir.path / "src.h5");
    const auto b = H5File::open(dir.path / "dst.h5");
    EXPECT_EQ(a.datasets("/"), b.datasets("/"));
    for (const std::string& p : a.datasets("/")) {
      SCOPED_TRACE(p);
      if (p == "/config/text") {
        EXPECT_EQ(a.read_string(p), b.read_string(p));
        continue;
      }
      const auto x = a.read<double>(p), y = b.read<double>(p);
      ASSERT_EQ(x.dims, y.dims);
      if (!x.data.empty()) {
        EXPECT_EQ(std::memcmp(x.data.data(), y.data.data(), 8 * x.data.size()), 0);
      }
      EXPECT_EQ(a.filters(p), b.filters(p));
    }
    EXPECT_EQ(b.filters("/frames/positions"), (std::vector<std::string>{"shuffle", "deflate"}));
    EXPECT_EQ(b.attribute<std::string>("/frames/positions", "units"), "a");
    EXPECT_EQ(b.attribute<std::int64_t>("/mesh", "level"), 1);
    EXPECT_EQ(b.attribute<std::string>("/", "run_id"), "x");
    EXPECT_EQ(b.read<double>("/mesh/sparse").data[0], -2.5);  // the fill value, from an unwritten chunk
  }
  // Creation properties and storage, through the C API (the files closed first: HDF5 refuses to open a file twice
  // with other access properties).
  const hid_t fa = H5Fopen((dir.path / "src.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t fb = H5Fopen((dir.path / "dst.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(fa, 0);
  ASSERT_GE(fb, 0);
  for (const char* p : {"/frames/positions", "/series/time", "/mesh/sparse", "/mesh/triangles"}) {
    SCOPED_TRACE(p);
    const hid_t da = H5Dopen2(fa, p, H5P_DEFAULT), db = H5Dopen2(fb, p, H5P_DEFAULT);
    const hid_t pa = H5Dget_create_plist(da), pb = H5Dget_create_plist(db);
    EXPECT_GT(H5Pequal(pa, pb), 0);
    EXPECT_EQ(H5Dget_storage_size(da), H5Dget_storage_size(db));  // chunks as stored, none added
    const hid_t sa = H5Dget_space(da), sb = H5Dget_space(db);
    hsize_t ma[3] = {}, mb[3] = {};
    H5Sget_simple_extent_dims(sa, nullptr, ma);
    H5Sget_simple_extent_dims(sb, nullptr, mb);
    EXPECT_EQ(std::vector<hsize_t>(ma, ma + 3), std::vector<hsize_t>(mb, mb + 3));
    for (hid_t h : {sa, sb}) H5Sclose(h);
    for (hid_t h : {pa, pb}) H5Pclose(h);
    for (hid_t h : {da, db}) H5Dclose(h);
  }
  H5L_info_t link;
  ASSERT_GE(H5Lget_info(fb, "/mesh/alias", &link, H5P_DEFAULT), 0);
  EXPECT_EQ(link.type, H5L_TYPE_SOFT);
  H5O_info_t t, same;
  H5Oget_info_by_name(fb, "/mesh/triangles", &t, H5P_DEFAULT);
  H5Oget_info_by_name(fb, "/mesh/same", &same, H5P_DEFAULT);
  EXPECT_EQ(t.addr, same.addr);
  EXPECT_EQ(t.rc, 2u);
  H5Fclose(fa);
  H5Fclose(fb);
}

// Single precision: stored as IEEE binary32, read back as float exactly and as double by widening; a record view
// of a float dataset is float too.
TEST(H5File, FloatDatasetsAndTheirViewsKeepSinglePrecision) {
  TempDir dir;
  const fs::path p = dir.path / "f32.h5";
  const std::vector<float> a = {1.0f / 3.0f, -0.0f, 3.4e38f, 1e-45f, 2.5f, -7.0f};
  {
    auto f = H5File::create(p);
    f.set_compression(4);
    f.append("/frames/t", a.data(), {3});
    f.append("/frames/t", a.data() + 3, {3});
    f.create_record_view("/views/t/1", "/frames/t", 1, {3});
  }
  const auto f = H5File::open(p);
  const auto r = f.read<float>("/frames/t");
  ASSERT_EQ(r.data.size(), a.size());
  EXPECT_EQ(std::memcmp(r.data.data(), a.data(), 4 * a.size()), 0);
  const auto view = f.read<float>("/views/t/1");
  EXPECT_EQ(std::memcmp(view.data.data(), a.data() + 3, 4 * 3), 0);
  EXPECT_EQ(f.read<double>("/views/t/1").data, (std::vector<double>{static_cast<double>(a[3]), 2.5, -7.0}));
  EXPECT_EQ(f.read<double>("/frames/t").data[0], static_cast<double>(1.0f / 3.0f));
}

TEST(H5File, TruncateThenAppend) {
  TempDir dir;
  const fs::path p = dir.path / "restart.h5";
  {
    auto f = H5File::create(p);
    f.create_extendable<std::int32_t>("/frames/id", {2}, 3);
    for (int k = 0; k < 10; ++k) {
      const double t = k;
      const std::int32_t id[2] = {k, -k};
      f.append("/series/time", &t, {});
      f.append("/frames/id", id, {2});
    }
  }
  {
    // A restart from a checkpoint taken after record 6: records 6..9 are dropped and written again.
    auto f = H5File::open(p, H5Access::ReadWrite);
    f.truncate("/series/time", 6);
    f.truncate("/frames/id", 6);
    EXPECT_THROW(f.truncate("/series/time", 7), std::invalid_argument);
    for (int k = 6; k < 8; ++k) {
      const double t = 100 + k;
      const std::int32_t id[2] = {100 + k, 0};
      f.append("/series/time", &t, {});
      f.append("/frames/id", id, {2});
    }
    f.truncate("/series/time", 8);  // no-op
  }
  {
    const auto f = H5File::open(p);
    EXPECT_EQ(f.read<double>("/series/time").data, (std::vector<double>{0, 1, 2, 3, 4, 5, 106, 107}));
    EXPECT_EQ(f.read<std::int32_t>("/frames/id").data,
              (std::vector<std::int32_t>{0, 0, 1, -1, 2, -2, 3, -3, 4, -4, 5, -5, 106, 0, 107, 0}));
  }  // HDF5 cannot hold one file open read-only and read-write at once in a process
  auto g = H5File::open(p, H5Access::ReadWrite);
  g.truncate("/series/time", 0);
  EXPECT_EQ(g.extent("/series/time"), 0u);
  EXPECT_TRUE(g.read<double>("/series/time").data.empty());
}

TEST(H5File, CreateRefusesExistingFileAndLeavesItByteIdentical) {
  TempDir dir;
  const fs::path p = dir.path / "run.h5";
  {
    auto f = H5File::create(p);
    f.write<double>("/x", {3}, std::vector<double>{1, 2, 3});
  }
  const std::string before = slurp(p);
  ASSERT_FALSE(before.empty());
  try {
    auto again = H5File::create(p);
    FAIL() << "an existing file was opened for writing";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(p.string()), std::string::npos) << e.what();
  }
  EXPECT_EQ(slurp(p), before);
  // Not an HDF5 file: also refused, also untouched.
  const fs::path text = dir.path / "notes.h5";
  { std::ofstream(text) << "not hdf5"; }
  EXPECT_THROW(H5File::create(text), InputError);
  EXPECT_EQ(slurp(text), "not hdf5");
  // With overwrite, the old content is gone.
  {
    auto f = H5File::create(p, true);
    EXPECT_FALSE(f.exists("/x"));
  }
  EXPECT_THROW(H5File::create(dir.path / "no" / "such" / "dir.h5"), InputError);
}

TEST(H5File, OpenErrorsNameTheFile) {
  TempDir dir;
  try {
    H5File::open(dir.path / "missing.h5");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.h5"), std::string::npos) << e.what();
  }
  const fs::path text = dir.path / "text.h5";
  { std::ofstream(text) << "plain text"; }
  EXPECT_THROW(H5File::open(text), InputError);

  const fs::path p = dir.path / "ok.h5";
  { H5File::create(p).create_group("/g"); }
  auto f = H5File::open(p);
  try {
    f.read<double>("/g/nope");
    FAIL();
  } catch (const H5Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("/g/nope"), std::string::npos) << m;
    EXPECT_NE(m.find(p.string()), std::string::npos) << m;
  }
  EXPECT_THROW(f.write_string("/s", "x"), H5Error);  // read-only
  EXPECT_THROW(f.append("/t", std::vector<double>{1.0}.data(), {}), H5Error);
  f.close();
  EXPECT_THROW(f.flush(), H5Error);
}

TEST(H5File, MoveTransfersOwnership) {
  TempDir dir;
  auto a = H5File::create(dir.path / "m.h5");
  H5File b = std::move(a);
  EXPECT_FALSE(a.is_open());  // NOLINT(bugprone-use-after-move): documented moved-from state
  EXPECT_TRUE(b.is_open());
  b.write_string("/s", "moved");
  b = H5File::create(dir.path / "n.h5");  // closes m.h5
  EXPECT_EQ(H5File::open(dir.path / "m.h5").read_string("/s"), "moved");
}

TEST(H5File, CheckpointIsReplacedOnlyOnSuccess) {
  TempDir dir;
  const fs::path ck = dir.path / "checkpoint.h5";
  write_checkpoint_atomically(ck, [](H5File& f) {
    f.set_attribute("/", "step", 100);
    f.write<double>("/state/x", {2}, std::vector<double>{1.0, 2.0});
  });
  const std::string good = slurp(ck);
  EXPECT_THROW(write_checkpoint_atomically(ck,
                                           [](H5File& f) {
                                             f.set_attribute("/", "step", 200);
                                             f.write<double>("/state/x", {2}, std::vector<double>{3.0, 4.0});
                                             f.flush();
                                             throw std::runtime_error("simulated failure mid-checkpoint");
                                           }),
               std::runtime_error);
  EXPECT_EQ(slurp(ck), good);
  EXPECT_EQ(dir.entries(), std::set<std::string>{"checkpoint.h5"});
  EXPECT_EQ(H5File::open(ck).attribute<std::int64_t>("/", "step"), 100);

  write_checkpoint_atomically(ck, [](H5File& f) { f.set_attribute("/", "step", 300); });
  EXPECT_EQ(H5File::open(ck).attribute<std::int64_t>("/", "step"), 300);
  EXPECT_FALSE(H5File::open(ck).exists("/state"));
  EXPECT_EQ(dir.entries(), std::set<std::string>{"checkpoint.h5"});
}

TEST(H5File, RngStateRoundTripGivesTheSameNextNumbers) {
  TempDir dir;
  const fs::path ck = dir.path / "rng.h5";
  std::mt19937_64 rng(2024);
  for (int i = 0; i < 12345; ++i) rng();  // mid-block state
  write_checkpoint_atomically(ck, [&](H5File& f) { write_rng_state(f, "/state/rng", rng); });
  std::mt19937_64 restored = read_rng_state(H5File::open(ck), "/state/rng");
  EXPECT_TRUE(restored == rng);
  std::mt19937_64 fresh(2024);
  bool differs_from_fresh = false;
  for (int i = 0; i < 1000; ++i) {
    const auto a = rng(), b = restored();
    ASSERT_EQ(a, b) << "draw " << i;
    differs_from_fresh |= fresh() != a;
  }
  EXPECT_TRUE(differs_from_fresh);
  EXPECT_THROW(rng_from_string("1 2 3"), InputError);
  EXPECT_THROW(rng_from_string(rng_to_string(rng) + " junk"), InputError);
}

TEST(H5File, FlushedButNeverClosedFileIsReadable) {
  TempDir dir;
  const fs::path p = dir.path / "killed.h5";
  const std::size_t nn = 50;
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    // Child: a run that dies right after a flush, without closing anything.
    int status = 0;
    try {
      auto f = H5File::create(p);
      f.write_string("/config/text", "steps = 5");
      std::vector<double> x(nn * 3);
      for (int k = 0; k < 5; ++k) {
        const double t = 0.1 * k;
        for (std::size_t i = 0; i < x.size(); ++i) x[i] = k + 1e-3 * static_cast<double>(i);
        f.append("/series/time", &t, {});
        f.append("/frames/positions", x.data(), {nn, 3});
      }
      f.flush();
      // Exit while `f` is still in scope: its destructor never runs, and _exit skips atexit handlers
      // (HDF5's H5close), so nothing but the flush has written the file.
      ::_exit(0);
    } catch (...) {
      status = 3;
    }
    ::_exit(status);
  }
  int wstatus = 0;
  ASSERT_EQ(::waitpid(pid, &wstatus, 0), pid);
  ASSERT_TRUE(WIFEXITED(wstatus));
  ASSERT_EQ(WEXITSTATUS(wstatus), 0) << "the child failed to write";
  const auto f = H5File::open(p);
  EXPECT_EQ(f.read_string("/config/text"), "steps = 5");
  const auto t = f.read<double>("/series/time");
  ASSERT_EQ(t.data.size(), 5u);
  EXPECT_DOUBLE_EQ(t.data[4], 0.4);
  const auto x = f.read<double>("/frames/positions");
  EXPECT_EQ(x.dims, (std::vector<std::size_t>{5, nn, 3}));
  EXPECT_DOUBLE_EQ(x.data.back(), 4 + 1e-3 * (nn * 3 - 1));
}

}  // namespace
}  // namespace capsflow::test
