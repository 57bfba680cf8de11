// A finished or stopped run's series, events and frame times are compressed when the run ends or stops
// (compress_finished_output); while the run lives they stay plain, because a compressed chunk is rewritten at a new place on every append and a kill
// could tear records its checkpoint covers (docs/output_format.md, "Compression and size"). These tests hold the
// numbers to the plain file's bit for bit, and the restarts that continue a compressed file to the uninterrupted run.
#include <gtest/gtest.h>

#include <csignal>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "host/base/h5_file.hpp"
#include "host/physics/config.hpp"
#include "host/run/run_driver.hpp"
#include "host/run/run_layout.hpp"
#include "support/run_files.hpp"
#include "support/small_run.hpp"
#include "support/temp_dir.hpp"

namespace {

using namespace capsflow;
namespace fs = std::filesystem;

const std::vector<std::string> kDeflated = {"shuffle", "deflate"};

// The small run to strain `end`, serial, with a record every 0.05 and a frame every 0.1 (contacts are not needed:
// the events are written through the same path as the series).
Config small(double end, const std::string& output_extra = "") {
  Config c = parse_config(test::small_run_text(output_extra), "<test>");
  c.run.backend = Backend::Serial;
  c.time.end = end;
  c.output.frames_every = 0.1;
  c.output.checkpoint_every = 10.0;
  return c;
}

// The datasets a run appends to record by record: compressed once it has ended.
bool appended_by_record(const layout::DatasetInfo& d) {
  return d.growth == layout::Growth::PerRecord || d.growth == layout::Growth::PerEvent ||
         std::string(d.path) == layout::kFrameTime;
}

std::string file_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Every numeric dataset of `a` (frame views included) is in `b` with the same shape and the same bits.
void expect_same_numbers(const fs::path& a, const fs::path& b) {
  const H5File fa = H5File::open(a), fb = H5File::open(b);
  const std::vector<std::string> names = fa.datasets();
  EXPECT_EQ(names, fb.datasets());
  for (const std::string& p : names) {
    if (p == layout::kConfig) continue;  // the one string dataset
    test::expect_same_dataset(fa, fb, p);
  }
}

TEST(SeriesCompression, AFinishedRunsSeriesAreCompressedAndReadBackEqual) {
  test::TempDir dir;
  ASSERT_EQ(run_simulation(small(0.3), test::quiet_run(dir.path / "deflated.h5"), std::cerr).exit_code, 0);
  Config plain = small(0.3);
  plain.output.compression = 0;
  ASSERT_EQ(run_simulation(plain, test::quiet_run(dir.path / "plain.h5"), std::cerr).exit_code, 0);

  const H5File a = H5File::open(dir.path / "deflated.h5"), b = H5File::open(dir.path / "plain.h5");
  int series = 0;
  for (const layout::DatasetInfo& d : layout::output_datasets()) {
    if (!appended_by_record(d)) continue;
    SCOPED_TRACE(d.path);
    ++series;
    EXPECT_EQ(a.filters(d.path), kDeflated);
    EXPECT_TRUE(b.filters(d.path).empty());
    EXPECT_EQ(a.attribute<std::string>(d.path, "units"), d.units);
  }
  EXPECT_GE(series, 20);
  EXPECT_EQ(a.attribute<std::int64_t>(layout::kProfile, "bins"), 50);
  for (const char* attr : {"capsflow_version", "units"})
    EXPECT_EQ(a.attribute<std::string>("/", attr), b.attribute<std::string>("/", attr)) << attr;
  EXPECT_EQ(a.attribute<std::int64_t>("/", "format_version"), layout::kFormatVersion);
  EXPECT_FALSE(a.attribute<std::string>("/", "run_id").empty());
  EXPECT_NE(a.read_string(layout::kConfig).find("compression = 4"), std::string::npos);
  expect_same_numbers(dir.path / "deflated.h5", dir.path / "plain.h5");
  EXPECT_LT(fs::file_size(dir.path / "deflated.h5"), fs::file_size(dir.path / "plain.h5"));
}

// Interrupted (a signal, a batch system's time limit, --stop-after-steps), the run is not live either: its series
// are compressed as at an end (issue 52, item 11); the continuation makes them plain again before it appends,
// compresses them at its end, and its numbers are those of the uninterrupted run.
TEST(SeriesCompression, AnInterruptedRunIsCompressedAndItsContinuationEndsBitForBit) {
  test::TempDir dir;
  const RunResult full = run_simulation(small(0.3), test::quiet_run(dir.path / "full.h5"), std::cerr);
  ASSERT_EQ(full.exit_code, 0);
  RunSettings s = test::quiet_run(dir.path / "part.h5");
  s.stop_after_steps = full.steps / 2;
  const RunResult part = run_simulation(small(0.3), s, std::cerr);
  ASSERT_EQ(part.exit_code, 128 + SIGINT);
  {
    const H5File f = H5File::open(dir.path / "part.h5");
    for (const layout::DatasetInfo& d : layout::output_datasets())
      if (appended_by_record(d)) {
        EXPECT_EQ(f.filters(d.path), kDeflated) << d.path;
      }
  }

  RunSettings cont;
  cont.quiet = true;
  cont.restart = part.checkpoint;
  ASSERT_EQ(run_simulation(small(0.3), cont, std::cerr).exit_code, 0);
  EXPECT_EQ(H5File::open(dir.path / "part.h5").filters(layout::kCentroid), kDeflated);
  expect_same_numbers(dir.path / "full.h5", dir.path / "part.h5");
}

// A finished (compressed) run extended by a restart: its series are made plain before they grow, compressed again at
// the new end, and every number is the uninterrupted run's. A restart with nothing to do changes no byte of it.
TEST(SeriesCompression, ACompressedRunExtendedByARestartEndsBitForBit) {
  test::TempDir dir;
  ASSERT_EQ(run_simulation(small(0.5), test::quiet_run(dir.path / "long.h5"), std::cerr).exit_code, 0);
  const RunResult first = run_simulation(small(0.25), test::quiet_run(dir.path / "ext.h5"), std::cerr);
  ASSERT_EQ(first.exit_code, 0);
  ASSERT_EQ(H5File::open(dir.path / "ext.h5").filters(layout::kTime), kDeflated);

  const std::string before = file_bytes(dir.path / "ext.h5");
  RunSettings again;
  again.quiet = true;
  again.restart = first.checkpoint;
  ASSERT_EQ(run_simulation(small(0.25), again, std::cerr).exit_code, 0);
  EXPECT_TRUE(file_bytes(dir.path / "ext.h5") == before) << "a restart with nothing to do rewrote the output";

  RunSettings more = again;
  more.end = 0.5;
  const RunResult second = run_simulation(small(0.25), more, std::cerr);
  ASSERT_EQ(second.exit_code, 0);
  EXPECT_GT(second.steps, 0);
  const H5File f = H5File::open(dir.path / "ext.h5");
  for (const layout::DatasetInfo& d : layout::output_datasets()) {
    if (appended_by_record(d)) {
      EXPECT_EQ(f.filters(d.path), kDeflated) << d.path;
    }
  }
  expect_same_numbers(dir.path / "long.h5", dir.path / "ext.h5");
}

}  // namespace
