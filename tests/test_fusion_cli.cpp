// moa odometry --fuse-camera end to end: a drifting dead reckoning pulled
// back by noisy position fixes.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "moa/analysis/evaluate.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/log.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

namespace fs = std::filesystem;

TrajectoryError errors_of(const fs::path& odometry, const std::vector<StampedPose>& truth) {
  TrajectoryErrorAccumulator acc(truth);
  io::TruthReader reader(odometry);
  while (const auto row = reader.next()) acc.add(row->t, row->pose);
  return acc.result();
}

TEST(FusionCli, CameraFixesBoundTheDriftOfWrongMounts) {
  const auto dir = test::scratch_dir("fusion");
  const SensorArray truth_array = test::skewed_array();
  const auto log = test::synthesise(truth_array, test::mixed_motion, 60.0, 0.01, true, 1e-3);
  test::write_log(log, truth_array, {"a", "b", "c", "d"}, dir);
  // The config the user believes: every scale 1 and positions 4 mm off.
  io::RobotConfig believed = io::read_config(dir / "robot.yaml");
  for (int i = 0; i < believed.array.size(); ++i) {
    believed.array[i].scale = {1.0, 1.0};
    believed.array[i].position += Eigen::Vector2d(0.004, -0.004);
  }
  io::write_config(believed, dir / "robot.yaml");
  // 10 Hz fixes with 5 mm noise, captured 50 ms before they arrive and
  // stamped on arrival (the config's camera latency, here --camera-latency).
  {
    std::mt19937_64 rng(60);
    std::normal_distribution<double> noise(0.0, 0.005);
    std::ofstream camera(dir / "camera.csv");
    camera << "t,x,y\n";
    for (std::size_t k = 0; k < log.truth.size(); k += 10) {
      const auto& s = log.truth[k];
      camera << s.t + 0.05 << ',' << s.pose.t.x() + noise(rng) << ',' << s.pose.t.y() + noise(rng)
             << '\n';
    }
  }
  const std::string common = "odometry --config " + (dir / "robot.yaml").string() + " --log " +
                             dir.string() + " --estimator ls --out ";
  ASSERT_EQ(test::run_moa(common + (dir / "dr.csv").string()).exit_code, 0);
  const auto fused =
      test::run_moa(common + (dir / "fused.csv").string() + " --fuse-camera --camera-latency 0.05");
  ASSERT_EQ(fused.exit_code, 0) << fused.err;
  const TrajectoryError dr = errors_of(dir / "dr.csv", log.truth);
  const TrajectoryError f = errors_of(dir / "fused.csv", log.truth);
  // Dead reckoning alone drifts well past the bounds the fusion must keep.
  EXPECT_GT(dr.max_translation, 0.1);
  EXPECT_LT(f.max_translation, 0.03);
  EXPECT_LT(f.max_heading, 0.12);
  std::ifstream header(dir / "fused.csv");
  std::string first;
  std::getline(header, first);
  EXPECT_NE(first.find("pxx"), std::string::npos);
  EXPECT_NE(first.find("ptt"), std::string::npos);
  std::printf("dead reckoning: max %.4f m %.4f rad; fused: max %.4f m %.4f rad, rms %.4f m\n",
              dr.max_translation, dr.max_heading, f.max_translation, f.max_heading,
              f.rms_translation);
  if (!HasFailure()) fs::remove_all(dir);
}

TEST(FusionCli, MissingCameraFileIsAnError) {
  const auto dir = test::scratch_dir("fusion-missing");
  const SensorArray array = test::skewed_array();
  test::write_log(test::synthesise(array, test::mixed_motion, 0.5, 0.01), array,
                  {"a", "b", "c", "d"}, dir);
  const auto r = test::run_moa("odometry --config " + (dir / "robot.yaml").string() + " --log " +
                               dir.string() + " --fuse-camera --out " + (dir / "o.csv").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("camera.csv"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "o.csv"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace moa
