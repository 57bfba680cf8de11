// `capsflow run CONFIG --from RUN.h5 [--frame N]` (issue 53, frame_start.hpp): a new run whose capsules are a frame
// of another run's output. What "equal" means here: a run started from the last frame and a restart from the
// checkpoint written at that frame hold the same state before their first step, bit for bit (positions, and the
// velocities, capsule velocities and geometry evaluated from them: the same reference shapes, the same operator,
// the same summation order on one backend). After it they part by design: the restart continues the AB2 history
// u^{n-1}, which a frame does not hold, so the branch's first step is Euler's, and its strain starts at 0.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "host/base/errors.hpp"
#include "host/base/h5_file.hpp"
#include "host/physics/config.hpp"
#include "host/physics/simulation.hpp"
#include "host/run/checkpoint.hpp"
#include "host/run/frame_start.hpp"
#include "host/run/run_driver.hpp"
#include "host/run/run_layout.hpp"
#include "support/cli_runner.hpp"
#include "support/run_files.hpp"
#include "support/small_run.hpp"
#include "support/temp_dir.hpp"

namespace {

using namespace capsflow;
namespace fs = std::filesystem;

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

std::vector<double> frame_of(const fs::path& h5, const char* path, long frame) {
  const H5File f = H5File::open(h5);
  const std::size_t n = f.extent(path);
  const std::size_t k = frame < 0 ? n - static_cast<std::size_t>(-frame) : static_cast<std::size_t>(frame);
  return f.read_records<double>(path, k, 1).data;
}

// Both simulations evaluated at their start: the same positions, node velocities, capsule velocities and volumes.
void expect_same_start(Simulation& a, Simulation& b) {
  a.evaluate();
  b.evaluate();
  EXPECT_TRUE(same_bits(a.positions(), b.positions()));
  EXPECT_TRUE(same_bits(a.ux(), b.ux()));
  EXPECT_TRUE(same_bits(a.uy(), b.uy()));
  EXPECT_TRUE(same_bits(a.uz(), b.uz()));
  EXPECT_TRUE(same_bits(a.capsule_velocity(), b.capsule_velocity()));
  EXPECT_TRUE(same_bits(a.geometry().volume, b.geometry().volume));
  EXPECT_TRUE(same_bits(a.initial_volumes(), b.initial_volumes()));  // the reference shapes' volumes
}

TEST(RunFromFrame, TheLastFrameStartsWhereARestartFromItsCheckpointStarts) {
  test::TempDir dir;
  const RunResult a = run_simulation(test::small_serial_config(0.2), test::quiet_run(dir.path / "a.h5"), std::cerr);
  ASSERT_EQ(a.exit_code, 0);
  // The restart's start: its checkpoint and the configuration stored in it.
  const Checkpoint ck = read_checkpoint(a.checkpoint);
  Simulation restarted(checkpoint_config(ck, a.checkpoint), ck.state, "");
  const FrameStart f = read_frame_start((dir.path / "a.h5").string(), std::nullopt);
  EXPECT_EQ(f.frame, 2u);
  EXPECT_EQ(f.strain, ck.state.time);  // the last frame is the end state, which the final checkpoint holds
  Simulation branched(test::small_serial_config(0.1), f.state, "");
  expect_same_start(restarted, branched);
  EXPECT_EQ(branched.time(), 0.0);

  // Through the driver: the branch's first record and frame are the source's last ones (positions, velocities).
  RunSettings s = test::quiet_run(dir.path / "b.h5");
  s.from = (dir.path / "a.h5").string();
  ASSERT_EQ(run_simulation(test::small_serial_config(0.1), s, std::cerr).exit_code, 0);
  const fs::path b = dir.path / "b.h5";
  EXPECT_TRUE(same_bits(frame_of(b, layout::kFramePositions, 0), ck.state.positions));
  EXPECT_TRUE(same_bits(frame_of(b, layout::kFrameVelocity, 0), frame_of(dir.path / "a.h5", layout::kFrameVelocity, -1)));
  EXPECT_TRUE(same_bits(frame_of(b, layout::kCentroid, 0), frame_of(dir.path / "a.h5", layout::kCentroid, -1)));
  const H5File h = H5File::open(b);
  EXPECT_EQ(h.attribute<std::string>("/", kAttrStartedFrom), fs::absolute(dir.path / "a.h5").string());
  EXPECT_EQ(h.attribute<std::int64_t>("/", kAttrStartedFromFrame), 2);
  EXPECT_EQ(h.attribute<double>("/", kAttrStartedFromStrain), ck.state.time);
  EXPECT_EQ(frame_of(b, layout::kFrameTime, 0), std::vector<double>{0.0});
}

// --frame N picks that frame; the configuration's physics is used (here a softer floppy capsule: other velocities).
TEST(RunFromFrame, AnEarlierFrameWithOtherPhysics) {
  test::TempDir dir;
  ASSERT_EQ(run_simulation(test::small_serial_config(0.2), test::quiet_run(dir.path / "a.h5"), std::cerr).exit_code, 0);
  RunSettings s = test::quiet_run(dir.path / "b.h5");
  s.from = (dir.path / "a.h5").string();
  s.from_frame = 1;
  Config soft = test::small_serial_config(0.1);
  soft.species[1].ca = 1.2;
  ASSERT_EQ(run_simulation(soft, s, std::cerr).exit_code, 0);
  const fs::path b = dir.path / "b.h5";
  EXPECT_TRUE(same_bits(frame_of(b, layout::kFramePositions, 0), frame_of(dir.path / "a.h5", layout::kFramePositions, 1)));
  EXPECT_FALSE(same_bits(frame_of(b, layout::kFrameVelocity, 0), frame_of(dir.path / "a.h5", layout::kFrameVelocity, 1)));
  EXPECT_EQ(H5File::open(b).read<double>(layout::kCapsuleCa).data, (std::vector<double>{0.2, 1.2}));
}

// The reference placement of a [suspension] run rebuilt from its configuration when its checkpoint is gone equals
// the checkpoint's; a run that itself started from a frame has only its checkpoint, and is refused without it.
TEST(RunFromFrame, TheReferencePlacementWithAndWithoutTheCheckpoint) {
  test::TempDir dir;
  Config c = parse_config(test::sweep_base_text(3), "base.toml");
  ASSERT_EQ(run_simulation(c, test::quiet_run(dir.path / "a.h5"), std::cerr).exit_code, 0);
  const FrameStart with = read_frame_start((dir.path / "a.h5").string(), -1);
  fs::rename(dir.path / "a.checkpoint.h5", dir.path / "a.ck.keep");
  const FrameStart without = read_frame_start((dir.path / "a.h5").string(), -1);
  EXPECT_TRUE(same_bits(with.state.initial_centres, without.state.initial_centres));
  EXPECT_TRUE(same_bits(with.state.initial_orientations, without.state.initial_orientations));
  EXPECT_EQ(with.state.species, without.state.species);

  RunSettings s = test::quiet_run(dir.path / "b.h5");
  s.from = (dir.path / "a.h5").string();
  ASSERT_EQ(run_simulation(c, s, std::cerr).exit_code, 0);
  // The branch of the branch takes the original placement from b's checkpoint.
  const FrameStart bb = read_frame_start((dir.path / "b.h5").string(), 0);
  EXPECT_TRUE(same_bits(bb.state.initial_centres, with.state.initial_centres));
  fs::remove(dir.path / "b.checkpoint.h5");
  try {
    read_frame_start((dir.path / "b.h5").string(), 0);
    ADD_FAILURE() << "a branch without its checkpoint was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("b.checkpoint.h5"), std::string::npos) << e.what();
  }
}

// Refusals: one line naming the file and what disagrees, exit status 2, nothing written.
TEST(RunFromFrame, ARunThatDoesNotFitTheFrameIsRefusedBeforeAnyFileIsWritten) {
  test::TempDir dir;
  const std::string base = test::small_run_text();
  {
    std::ofstream(dir.path / "small.toml") << base;
    std::ofstream(dir.path / "three.toml")
        << test::small_run_text("[[capsule]]\nspecies = \"stiff\"\ncenter = [3.0, 3.0, 0.5]\n");
  }
  ASSERT_EQ(test::run_capsflow(dir.path, "run small.toml --output a.h5 -q --backend serial --set time.end=0.2 "
                                          "--set output.frames_every=0.1")
                .status, 0);
  const auto before = test::snapshot_files(dir.path);
  const std::string b = " --output b.h5 -q --backend serial";
  test::expect_input_error(test::run_capsflow(dir.path, "run three.toml --from a.h5" + b),
                           {"a.h5 frame 2 and three.toml disagree", "capsule count 2 in the frame, 3 in CONFIG"});
  test::expect_input_error(test::run_capsflow(dir.path, "run small.toml --from a.h5 --set capsules.mesh_level=2" + b),
                           {"a.h5 frame 2", "mesh level 1 in the frame, 2 in CONFIG"});
  test::expect_input_error(test::run_capsflow(dir.path, "run small.toml --from a.h5 --set species.2.name=soft "
                                                          "--set capsule.2.species=soft" + b),
                           {"species 2 is 'floppy' in the frame, 'soft' in CONFIG"});
  test::expect_input_error(test::run_capsflow(dir.path, "run small.toml --from a.h5 --set capsule.2.species=stiff" + b),
                           {"[[capsule]] 2 is of species 'stiff' in CONFIG, 'floppy' in the frame"});
  test::expect_input_error(test::run_capsflow(dir.path, "run small.toml --from a.h5 --set capsule.1.pinned=true" + b),
                           {"[[capsule]] 1 is not pinned in the frame, pinned in CONFIG"});
  test::expect_input_error(
      test::run_capsflow(dir.path, "run small.toml --from a.h5 --set species.stiff.radius=1.1" + b),
      {"species 'stiff' radius 1 in the frame, 1.1 in CONFIG"});
  test::expect_input_error(test::run_capsflow(dir.path, "run small.toml --from a.h5 --set capsules.inflation=0.1" + b),
                           {"species 'stiff' inflation 0.05 in the frame, 0.1 in CONFIG"});
  test::expect_input_error(test::run_capsflow(dir.path, "run small.toml --from a.h5 --frame 7" + b),
                           {"--frame 7", "a.h5 has 3 frames"});
  test::expect_input_error(test::run_capsflow(dir.path, "run small.toml --from none.h5" + b), {"--from none.h5: no such file"});
  test::expect_input_error(test::run_capsflow(dir.path, "run small.toml --from small.toml" + b),
                           {"--from small.toml: expected a capsflow run's output"});
  test::expect_input_error(test::run_capsflow(dir.path, "run --from a.h5" + b), {"--from a.h5: needs CONFIG"});
  test::expect_input_error(test::run_capsflow(dir.path, "run small.toml --frame 0" + b), {"--frame: needs --from"});
  test::expect_input_error(test::run_capsflow(dir.path, "run small.toml --from a.h5 --output a.h5 --force -q"),
                           {"a.h5"});
  EXPECT_EQ(test::snapshot_files(dir.path), before);
}

}  // namespace
