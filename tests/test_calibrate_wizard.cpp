// moa calibrate --guided --live in a pseudo-terminal, driven like a user
// with a scripted replay (the 'guided' scenario: a push that turns, then
// good pushes along x and y and three turns), and the motion checks of
// calibration/guided_steps.hpp on synthetic epochs.
#include <fcntl.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include "moa/calibration/guided_session.hpp"
#include "moa/calibration/guided_steps.hpp"
#include "moa/core/array.hpp"
#include "moa/formats/config.hpp"
#include "support/pty_moa.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using test::PtyMoa;

// A scratch folder `name` with a simulated guided session (scenario guided,
// `seed`) in its log/.
fs::path simulated_session(const std::string& name, int seed) {
  const fs::path dir = test::scratch_dir(name);
  const auto sim = test::run_moa("simulate --scenario guided --seed " + std::to_string(seed) +
                                 " --out " + (dir / "log").string());
  EXPECT_EQ(sim.exit_code, 0) << sim.err;
  return dir;
}

TEST(CalibrateWizard, WalksThroughEveryStepWithARedoAndWritesTheCalibration) {
  const fs::path dir = simulated_session("calibrate-wizard", 2);
  ASSERT_FALSE(HasFailure());
  // 31 s of log at 4x: ~8 s. Every answer is typed within milliseconds of
  // its question, well inside the 3 s (0.75 s at 4x) the robot rests.
  PtyMoa moa({"calibrate", "--guided", "--live", "--config", (dir / "log" / "robot.yaml").string(),
              "--replay", (dir / "log").string(), "--speed", "4", "--distance", "1", "--turns", "3",
              "--out", (dir / "cal.yaml").string()});
  const auto deadline = Clock::now() + std::chrono::seconds(40);

  ASSERT_TRUE(moa.wait_for("Step 1 of 3: push along x", 1, deadline)) << moa.output();
  ASSERT_TRUE(moa.wait_for("Not good enough", 1, deadline)) << moa.output();
  // The reason follows on its own line: wait for it rather than race it.
  EXPECT_TRUE(moa.wait_for("turned while pushing", 1, deadline)) << moa.output();
  moa.type("r");
  ASSERT_TRUE(moa.wait_for("Again.", 1, deadline)) << moa.output();
  ASSERT_TRUE(moa.wait_for("Good enough.", 1, deadline)) << moa.output();
  moa.type("\r");
  ASSERT_TRUE(moa.wait_for("Step 2 of 3: push along y", 1, deadline)) << moa.output();
  ASSERT_TRUE(moa.wait_for("Good enough.", 2, deadline)) << moa.output();
  moa.type("\r");
  ASSERT_TRUE(moa.wait_for("Step 3 of 3: spin", 1, deadline)) << moa.output();
  ASSERT_TRUE(moa.wait_for("Good enough.", 3, deadline)) << moa.output();
  // The nominal mounts see 2.96 turns: within 0.1 of the 3 asked for.
  EXPECT_THAT(moa.output(), HasSubstr(" turns counter-clockwise in "));
  moa.type("\r");
  ASSERT_TRUE(moa.wait_for("calibrated config written to", 1, deadline)) << moa.output();
  EXPECT_EQ(moa.exit_code(10.0), 0) << moa.output();
  EXPECT_EQ(moa.occurrences("Kept."), 3);
  EXPECT_EQ(moa.occurrences("Not good enough"), 1) << moa.output();
  EXPECT_THAT(moa.output(), HasSubstr("1-sigma"));

  // What the wizard wrote is the simulated robot: positions to 0.2 mm,
  // yaws to 0.05 deg, scales to 0.2 %, m2's mirroring found.
  const io::RobotConfig cal = io::read_config(dir / "cal.yaml");
  const io::RobotConfig truth = io::read_config(dir / "log" / "robot.true.yaml");
  ASSERT_EQ(cal.array.size(), truth.array.size());
  for (int i = 0; i < truth.array.size(); ++i) {
    EXPECT_LT((cal.array[i].position - truth.array[i].position).norm(), 2e-4) << i;
    EXPECT_NEAR(cal.array[i].yaw, truth.array[i].yaw, 0.05 * std::numbers::pi / 180) << i;
    EXPECT_NEAR(cal.array[i].scale.x(), truth.array[i].scale.x(), 2e-3) << i;
    EXPECT_NEAR(cal.array[i].scale.y(), truth.array[i].scale.y(), 2e-3) << i;
    EXPECT_EQ(cal.array[i].mirrored, truth.array[i].mirrored) << i;
  }
  // The spin calibrated the gyro (3 % off in scale, biased -0.02 rad/s, 8 ms
  // late; robot.yaml knows none of it) against the array at those mounts,
  // with the 1-sigma the wizard printed: the truth within 4 of them. The
  // bias walks (3e-5 rad/s/sqrt(s)) over the 25 s from the start to the
  // spin's end: its sd there, 1.5e-4 rad/s, is added to the bias's.
  ASSERT_TRUE(cal.imu.has_value());
  ASSERT_TRUE(truth.imu.has_value());
  const auto sigma = [&](const std::string& row) {
    // "  scale   1.00000   1.02982   0.00012": the last number of the row.
    const std::string out = moa.output();
    const auto at = out.find("\n  " + row);
    EXPECT_NE(at, std::string::npos) << row << "\n" << out;
    if (at == std::string::npos) return 0.0;
    const auto end = out.find('\n', at + 1);
    return std::stod(out.substr(out.rfind(' ', end) + 1, end));
  };
  EXPECT_THAT(moa.output(), HasSubstr("gyro against the array"));
  const double sk = sigma("scale  "), sb = sigma("bias rad/s"), sl = sigma("latency ms") * 1e-3;
  EXPECT_GT(sk, 0.0);
  EXPECT_LT(std::abs(cal.imu->scale - truth.imu->scale), 4.0 * sk) << cal.imu->scale;
  EXPECT_LT(std::abs(cal.imu->bias - truth.imu->bias), 4.0 * std::hypot(sb, 1.5e-4))
      << cal.imu->bias;
  EXPECT_LT(std::abs(cal.imu->latency - truth.imu->latency), 4.0 * sl) << cal.imu->latency;
  if (!HasFailure()) fs::remove_all(dir);
}

// A gyro whose rows are not the spin's motion (imu.csv replaced by noise)
// is refused as `--method guided` refuses it: nothing written, and the
// message names --no-imu, the way to keep the mice's calibration.
TEST(CalibrateWizard, AGyroOfAnotherMotionIsRefusedAndNothingWritten) {
  const fs::path dir = simulated_session("calibrate-wizard-bad-gyro", 2);
  ASSERT_FALSE(HasFailure());
  {
    std::ofstream imu(dir / "log" / "imu.csv");
    imu << "t,gz\n";
    for (int k = 1; k <= 3100; ++k)
      imu << k * 0.01 << "," << ((k * 7919) % 101 - 50) * 0.01 << "\n";
  }
  PtyMoa moa({"calibrate", "--guided", "--live", "--config", (dir / "log" / "robot.yaml").string(),
              "--replay", (dir / "log").string(), "--speed", "8", "--distance", "1", "--turns", "3",
              "--out", (dir / "cal.yaml").string()});
  const auto deadline = Clock::now() + std::chrono::seconds(40);
  ASSERT_TRUE(moa.wait_for("turned while pushing", 1, deadline)) << moa.output();
  moa.type("r");
  for (int k = 1; k <= 3; ++k) {
    ASSERT_TRUE(moa.wait_for("Good enough.", k, deadline)) << moa.output();
    moa.type("\r");
  }
  EXPECT_EQ(moa.exit_code(10.0), 1) << moa.output();
  EXPECT_THAT(moa.output(), HasSubstr("gyro calibration against array refused"));
  EXPECT_THAT(moa.output(), HasSubstr("Nothing written (--no-imu calibrates the mice alone)"));
  EXPECT_FALSE(fs::exists(dir / "cal.yaml"));
  if (!HasFailure()) fs::remove_all(dir);
}

TEST(CalibrateWizard, QuitWritesNothing) {
  const fs::path dir = simulated_session("calibrate-wizard-quit", 1);
  ASSERT_FALSE(HasFailure());
  PtyMoa moa({"calibrate", "--guided", "--live", "--config", (dir / "log" / "robot.yaml").string(),
              "--replay", (dir / "log").string(), "--speed", "4", "--out",
              (dir / "cal.yaml").string()});
  const auto deadline = Clock::now() + std::chrono::seconds(20);
  ASSERT_TRUE(moa.wait_for("Hold the robot still", 1, deadline)) << moa.output();
  moa.type("q");
  EXPECT_EQ(moa.exit_code(10.0), 1) << moa.output();
  EXPECT_THAT(moa.output(), HasSubstr("nothing written"));
  EXPECT_FALSE(fs::exists(dir / "cal.yaml"));
  fs::remove_all(dir);
}

// Late keys: at 20x, each answer typed 1.5 s after its question (30 s of
// log, the whole of it) would have let the replay run past every motion
// and end. The replay waits for the wizard: no motion is skipped, and the
// last key, typed after the data's last row was read, still writes.
TEST(CalibrateWizard, TheReplayWaitsForLateKeys) {
  const fs::path dir = simulated_session("calibrate-wizard-late", 2);
  ASSERT_FALSE(HasFailure());
  PtyMoa moa({"calibrate", "--guided", "--live", "--config", (dir / "log" / "robot.yaml").string(),
              "--replay", (dir / "log").string(), "--speed", "20", "--distance", "1", "--turns",
              "3", "--no-imu", "--out", (dir / "cal.yaml").string()});
  const auto deadline = Clock::now() + std::chrono::seconds(40);
  const auto late = [&](const std::string& key) {
    moa.wait_for("\x01never\x01", 1, Clock::now() + std::chrono::milliseconds(1500));
    moa.type(key);
  };
  ASSERT_TRUE(moa.wait_for("Keys: ", 1, deadline)) << moa.output();
  EXPECT_TRUE(moa.wait_for("k keeps one that failed a check", 1, deadline)) << moa.output();
  ASSERT_TRUE(moa.wait_for("turned while pushing", 1, deadline)) << moa.output();
  late("r");
  ASSERT_TRUE(moa.wait_for("Good enough.", 1, deadline)) << moa.output();
  late("\r");
  ASSERT_TRUE(moa.wait_for("Good enough.", 2, deadline)) << moa.output();
  late("\r");
  ASSERT_TRUE(moa.wait_for("Good enough.", 3, deadline)) << moa.output();
  late("\r");
  ASSERT_TRUE(moa.wait_for("calibrated config written to", 1, deadline)) << moa.output();
  EXPECT_EQ(moa.exit_code(10.0), 0) << moa.output();
  EXPECT_EQ(moa.occurrences("Kept."), 3) << moa.output();
  EXPECT_EQ(moa.occurrences("Again."), 1) << moa.output();
  // --no-imu: the gyro left as the nominal config has it.
  EXPECT_THAT(moa.output(), Not(HasSubstr("gyro against")));
  const io::RobotConfig nominal = io::read_config(dir / "log" / "robot.yaml");
  const io::RobotConfig cal = io::read_config(dir / "cal.yaml");
  ASSERT_TRUE(cal.imu.has_value() && nominal.imu.has_value());
  EXPECT_EQ(cal.imu->scale, nominal.imu->scale);
  EXPECT_EQ(cal.imu->bias, nominal.imu->bias);
  EXPECT_EQ(cal.imu->latency, nominal.imu->latency);
  if (!HasFailure()) fs::remove_all(dir);
}

// ------------------------------------------------ the checks on synthetic epochs

/// Epochs of 10 ms at a constant twist, counts from the measurement model.
class Epochs {
 public:
  explicit Epochs(const SensorArray& array) : array_(array) { sample_.size = array.size(); }
  std::optional<MotionSummary> run(MotionWatcher& watcher, const Twist2& twist, double seconds,
                                   std::uint8_t flags = 0) {
    std::optional<MotionSummary> out;
    each(twist, seconds, flags, [&](const OdometryStep& step) {
      if (auto s = watcher.feed(step)) out = s;
    });
    return out;
  }
  /// The same epochs fed to a session: the events it said, in order.
  std::vector<GuidedSession::Event> run(GuidedSession& session, const Twist2& twist,
                                        double seconds) {
    std::vector<GuidedSession::Event> events;
    each(twist, seconds, 0, [&](const OdometryStep& step) {
      const auto e = session.feed(step);
      if (e != GuidedSession::Event::kNone) events.push_back(e);
    });
    return events;
  }

 private:
  template <class Feed>
  void each(const Twist2& twist, double seconds, std::uint8_t flags, Feed&& feed) {
    const double dt = 0.01;
    for (int k = 0; k < static_cast<int>(std::lround(seconds / dt)); ++k) {
      sample_.t += dt;
      sample_.dt = dt;
      for (int i = 0; i < array_.size(); ++i) {
        const auto s = static_cast<std::size_t>(i);
        sample_.counts[s] = array_[i].counts(twist, dt);
        sample_.flags[s] = flags;
      }
      pose_ = integrate_exact(pose_, twist, dt);
      OdometryStep step;
      step.sample = &sample_;
      step.estimate.estimate.twist = twist;
      step.pose = pose_;
      feed(step);
    }
  }

  SensorArray array_;
  ArraySample sample_;
  Pose2 pose_;
};

SensorArray square_array() {
  SensorArray array = regular_polygon(4, 0.1, std::numbers::pi / 4);
  for (int i = 0; i < 4; ++i) array[i].max_speed = 0.5;
  return array;
}

std::vector<MotionProblem> problems_of(GuidedStep step, const Twist2& twist, double seconds,
                                       std::uint8_t flags = 0) {
  const SensorArray array = square_array();
  MotionWatcher watcher(array, MotionLimits{});
  Epochs epochs(array);
  watcher.arm(step);
  EXPECT_FALSE(epochs.run(watcher, Twist2{}, 1.0));
  EXPECT_EQ(watcher.state(), MotionWatcher::State::kReady);
  EXPECT_FALSE(epochs.run(watcher, twist, seconds, flags));
  EXPECT_EQ(watcher.state(), MotionWatcher::State::kMoving);
  const auto summary = epochs.run(watcher, Twist2{}, 1.0);
  EXPECT_TRUE(summary);
  return summary ? summary->problems : std::vector<MotionProblem>{};
}

TEST(MotionWatcher, AGoodPushAndSpinPassAndGiveTheModelsTotals) {
  EXPECT_TRUE(problems_of(GuidedStep::kPushX, {{0.25, 0.0}, 0.0}, 4.0).empty());
  EXPECT_TRUE(problems_of(GuidedStep::kPushY, {{0.0, 0.2}, 0.0}, 5.0).empty());
  EXPECT_TRUE(problems_of(GuidedStep::kSpin, {{0.0, 0.0}, std::numbers::pi}, 6.0).empty());

  const SensorArray array = square_array();
  MotionWatcher watcher(array, MotionLimits{});
  Epochs epochs(array);
  watcher.arm(GuidedStep::kPushX);
  epochs.run(watcher, Twist2{}, 1.0);
  epochs.run(watcher, {{0.25, 0.0}, 0.0}, 4.0);
  const auto s = epochs.run(watcher, Twist2{}, 1.0);
  ASSERT_TRUE(s);
  EXPECT_NEAR(s->displacement.x(), 1.0, 1e-9);
  ASSERT_EQ(s->totals.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d expected = array[i].counts({{1.0, 0.0}, 0.0}, 1.0);
    EXPECT_LT((s->totals[static_cast<std::size_t>(i)] - expected).norm(), 1e-6) << i;
  }
}

TEST(MotionWatcher, SaysWhatIsWrongWithABadMotion) {
  using P = MotionProblem;
  using ::testing::Contains;
  EXPECT_THAT(problems_of(GuidedStep::kPushX, {{0.25, 0.0}, 0.0}, 2.0), Contains(P::kTooShort));
  EXPECT_THAT(problems_of(GuidedStep::kPushX, {{0.25, 0.0}, 0.0}, 6.0), Contains(P::kTooLong));
  EXPECT_THAT(problems_of(GuidedStep::kPushX, {{0.25, 0.05}, 0.0}, 4.0), Contains(P::kOffAxis));
  EXPECT_THAT(problems_of(GuidedStep::kPushX, {{0.25, 0.0}, 0.2}, 4.0), Contains(P::kTurned));
  EXPECT_THAT(problems_of(GuidedStep::kPushX, {{0.45, 0.0}, 0.0}, 2.2), Contains(P::kTooFast));
  EXPECT_THAT(problems_of(GuidedStep::kPushX, {{0.25, 0.0}, 0.0}, 4.0, kFlagLift),
              Contains(P::kLifted));
  EXPECT_THAT(problems_of(GuidedStep::kSpin, {{0.0, 0.0}, std::numbers::pi}, 5.0),
              Contains(P::kTooFewTurns));
  EXPECT_THAT(problems_of(GuidedStep::kSpin, {{0.0, 0.0}, std::numbers::pi}, 7.0),
              Contains(P::kTooManyTurns));
  // About a point 5 cm ahead of the centre: v = -omega J c.
  EXPECT_THAT(
      problems_of(GuidedStep::kSpin, {{0.0, -std::numbers::pi * 0.05}, std::numbers::pi}, 6.0),
      Contains(P::kOffCentre));
}

// ------------------------------------------------ the session's decisions

TEST(GuidedSession, AsksForEachMotionInTurnAndHandsTheKeptTotalsToTheSolver) {
  using E = GuidedSession::Event;
  const SensorArray array = square_array();
  GuidedSession session(array, MotionLimits{}, /*push_y=*/true);
  ASSERT_EQ(session.steps(),
            (std::vector<GuidedStep>{GuidedStep::kPushX, GuidedStep::kPushY, GuidedStep::kSpin}));
  EXPECT_EQ(session.pending(), nullptr);
  EXPECT_FALSE(session.keep(/*force=*/true));  // nothing watched yet
  EXPECT_FALSE(session.redo());
  session.begin_step();
  Epochs epochs(array);
  // Still, then 1 m along x at 0.25 m/s, then still: ready, moving, watched.
  EXPECT_EQ(epochs.run(session, Twist2{}, 1.0), (std::vector<E>{E::kReady}));
  EXPECT_EQ(epochs.run(session, {{0.25, 0.0}, 0.0}, 4.0), (std::vector<E>{E::kMoving}));
  EXPECT_EQ(epochs.run(session, Twist2{}, 1.0), (std::vector<E>{E::kWatched}));
  ASSERT_NE(session.pending(), nullptr);
  EXPECT_TRUE(session.pending()->good());
  // Redone: the same motion is asked for again, and watched again.
  EXPECT_TRUE(session.redo());
  EXPECT_EQ(session.current(), 0u);
  EXPECT_EQ(session.pending(), nullptr);
  epochs.run(session, Twist2{}, 1.0);
  epochs.run(session, {{0.25, 0.0}, 0.0}, 4.0);
  EXPECT_EQ(epochs.run(session, Twist2{}, 1.0), (std::vector<E>{E::kWatched}));
  EXPECT_TRUE(session.keep(/*force=*/false));
  EXPECT_EQ(session.current(), 1u);
  // A push along y that stops short (0.5 m of 1 m) fails: kept only by force.
  epochs.run(session, Twist2{}, 1.0);
  epochs.run(session, {{0.0, 0.25}, 0.0}, 2.0);
  epochs.run(session, Twist2{}, 1.0);
  ASSERT_NE(session.pending(), nullptr);
  EXPECT_FALSE(session.pending()->good());
  EXPECT_FALSE(session.keep(/*force=*/false));
  EXPECT_EQ(session.current(), 1u);
  EXPECT_TRUE(session.keep(/*force=*/true));
  // Three turns counter-clockwise.
  epochs.run(session, Twist2{}, 1.0);
  epochs.run(session, {{0.0, 0.0}, std::numbers::pi}, 6.0);
  epochs.run(session, Twist2{}, 1.0);
  EXPECT_TRUE(session.keep(/*force=*/false));
  EXPECT_TRUE(session.complete());

  // The totals are the measurement model's counts of each kept motion.
  const GuidedInput in = session.input();
  ASSERT_TRUE(in.push_y);
  for (int i = 0; i < 4; ++i) {
    const auto u = static_cast<std::size_t>(i);
    EXPECT_LT((in.push_x[u] - array[i].counts({{1.0, 0.0}, 0.0}, 1.0)).norm(), 1e-6) << i;
    EXPECT_LT(((*in.push_y)[u] - array[i].counts({{0.0, 0.5}, 0.0}, 1.0)).norm(), 1e-6) << i;
    EXPECT_LT((in.spin[u] - array[i].counts({{0.0, 0.0}, 6.0 * std::numbers::pi}, 1.0)).norm(),
              1e-6)
        << i;
  }
  EXPECT_EQ(in.distance, MotionLimits{}.distance);
  EXPECT_EQ(in.turns, MotionLimits{}.turns);
}

TEST(GuidedSession, WithoutThePushAlongYAsksForTwoMotionsAndGivesNoPushY) {
  const SensorArray array = square_array();
  GuidedSession session(array, MotionLimits{}, /*push_y=*/false);
  EXPECT_EQ(session.steps(), (std::vector<GuidedStep>{GuidedStep::kPushX, GuidedStep::kSpin}));
  session.begin_step();
  Epochs epochs(array);
  for (const Twist2& motion : {Twist2{{0.25, 0.0}, 0.0}, Twist2{{0.0, 0.0}, std::numbers::pi}}) {
    epochs.run(session, Twist2{}, 1.0);
    epochs.run(session, motion, motion.omega != 0.0 ? 6.0 : 4.0);
    epochs.run(session, Twist2{}, 1.0);
    EXPECT_TRUE(session.keep(false));
  }
  EXPECT_TRUE(session.complete());
  EXPECT_FALSE(session.input().push_y);
}

TEST(GuidedSession, InstructionsSayTheDistanceAndTheDirectionOfTheTurns) {
  MotionLimits limits;
  limits.distance = 0.5;
  EXPECT_THAT(instructions(GuidedStep::kPushX, limits), HasSubstr("Push it 0.5 m forward (+x)"));
  EXPECT_THAT(instructions(GuidedStep::kPushY, limits), HasSubstr("0.5 m to its left (+y)"));
  limits.turns = -1.0;
  EXPECT_THAT(instructions(GuidedStep::kSpin, limits), HasSubstr("1 whole turn clockwise"));
  limits.turns = 2.0;
  EXPECT_THAT(instructions(GuidedStep::kSpin, limits),
              HasSubstr("2 whole turns counter-clockwise"));
}

TEST(GuidedSession, ResultWarningsSayAShiftedCentreAndPushesThatDisagree) {
  GuidedCalibration cal;
  cal.centroid_shift = {0.0025, -0.002};  // 3.2 mm: over the 3 mm bound
  cal.push_misfit = {0.004, 0.006};       // the 0.5 % bound of a 1 m push is 5 mm
  EXPECT_EQ(guided_result_warnings(cal, 1.0, {"a", "b"}),
            (std::vector<std::string>{
                "the sensors' mean position moved by (2.5, -2.0) mm from nominal: if the spin was "
                "not about the robot's centre, every position is shifted by that offset",
                "b: the two pushes disagree with one sensor frame by 6.0 mm: were they "
                "perpendicular and without turning?"}));
  // Within the bounds (2 m pushes: 10 mm), nothing to say.
  cal.centroid_shift = {0.002, 0.002};  // 2.8 mm
  EXPECT_TRUE(guided_result_warnings(cal, 2.0, {"a", "b"}).empty());
}

}  // namespace
}  // namespace moa
