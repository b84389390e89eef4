// SparkFun's OTOS as a source (sources/otos_registers.hpp, otos_unit.hpp,
// otos_reader.hpp): the register scalings against the figures of its
// register map computed here, the turn-back of its velocity into its own
// frame, a simulated robot read through the register model into the
// pipeline of `moa live --otos`, and every bad input: a wrong product ID, a
// unit that stops answering and comes back, tracking lost, tilt, corrupt and
// impossible reads, bad options and flags.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include <unistd.h>

#include "moa/core/array.hpp"
#include "moa/formats/config.hpp"
#include "moa/runs/live_source.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/runs/run_loop.hpp"
#include "moa/sources/i2c_dev.hpp"
#include "moa/sources/otos_reader.hpp"
#include "moa/sources/otos_registers.hpp"
#include "moa/sources/otos_unit.hpp"
#include "support/error_of.hpp"
#include "support/otos_model.hpp"
#include "support/run.hpp"

namespace moa::test {
namespace {

namespace otos = io::otos;
using Bytes6 = std::array<std::uint8_t, 6>;
using io::RobotConfig;

// ---------------------------------------------------------------- registers

TEST(OtosRegisters, ScalesAreTheRegisterMapsFullScalesOver32768) {
  // Full scales of the register map: 10 m, 5 m/s, 16 g, pi rad, 2000 deg/s,
  // 1000 pi rad/s^2, each over 2^15.
  EXPECT_DOUBLE_EQ(otos::kPositionLsb, 0.00030517578125);        // 10 / 32768 m, exact in binary
  EXPECT_DOUBLE_EQ(otos::kVelocityLsb, 0.000152587890625);       // 5 / 32768 m/s
  EXPECT_NEAR(otos::kHeadingLsb, 9.587379924285257e-05, 1e-18);  // pi / 32768 rad
  EXPECT_NEAR(otos::kRateLsb, 34.906585039886591 / 32768.0, 1e-18);
  EXPECT_NEAR(otos::kAccelerationLsb, 156.9064 / 32768.0, 1e-15);
  EXPECT_NEAR(otos::kAngularAccelerationLsb, 3141.5926535897932 / 32768.0, 1e-15);
  EXPECT_NEAR(otos::kLoopRate, 416.6667, 1e-4);
}

TEST(OtosRegisters, TriplesAreLittleEndianInt16) {
  // x = -32768 (0x8000), y = 32767 (0x7FFF), h = 1 (0x0001), low byte first.
  const Bytes6 bytes{0x00, 0x80, 0xFF, 0x7F, 0x01, 0x00};
  const otos::RawTriple raw = otos::decode_raw(bytes);
  EXPECT_EQ(raw.x, -32768);
  EXPECT_EQ(raw.y, 32767);
  EXPECT_EQ(raw.h, 1);
  const otos::Triple v = otos::to_si(raw, otos::kVelocityScale);
  EXPECT_DOUBLE_EQ(v.xy.x(), -5.0);
  EXPECT_DOUBLE_EQ(v.xy.y(), 5.0 * 32767.0 / 32768.0);
  EXPECT_DOUBLE_EQ(v.h, 2000.0 * std::numbers::pi / 180.0 / 32768.0);
  Bytes6 back{};
  otos::encode_raw(raw, back);
  EXPECT_EQ(back, bytes);
  // 0x1234 = 4660: 4660 x 10 / 32768 m of position.
  const Bytes6 position{0x34, 0x12, 0xCC, 0xED, 0x00, 0x40};  // 4660, -4660, 16384
  const otos::Triple p = otos::to_si(otos::decode_raw(position), otos::kPositionScale);
  EXPECT_DOUBLE_EQ(p.xy.x(), 4660.0 * 10.0 / 32768.0);
  EXPECT_DOUBLE_EQ(p.xy.y(), -4660.0 * 10.0 / 32768.0);
  EXPECT_DOUBLE_EQ(p.h, std::numbers::pi / 2.0);  // 16384 = half of full scale pi
}

TEST(OtosRegisters, WritingRoundsToTheNearestStepAndSaturates) {
  const otos::RawTriple raw = otos::to_raw(
      {Vec2(1.2 * otos::kVelocityLsb, -2.5 * otos::kVelocityLsb), 99.0}, otos::kVelocityScale);
  EXPECT_EQ(raw.x, 1);
  EXPECT_EQ(raw.y, -3);     // half away from zero
  EXPECT_EQ(raw.h, 32767);  // 99 rad/s is beyond 2000 deg/s: saturated
  EXPECT_EQ(otos::to_raw({Vec2(-7.0, 0.0), 0.0}, otos::kVelocityScale).x, -32768);
}

TEST(OtosRegisters, ScalarsAreOnePlusATenthOfAPercentPerStep) {
  EXPECT_DOUBLE_EQ(otos::scalar_from_register(0x00), 1.0);
  EXPECT_DOUBLE_EQ(otos::scalar_from_register(0x7F), 1.127);
  EXPECT_DOUBLE_EQ(otos::scalar_from_register(0x80), 0.872);
  EXPECT_DOUBLE_EQ(otos::scalar_from_register(0xFF), 0.999);
  EXPECT_EQ(otos::scalar_register(1.0), 0x00);
  EXPECT_EQ(otos::scalar_register(1.127), 0x7F);
  EXPECT_EQ(otos::scalar_register(0.872), 0x80);
  EXPECT_EQ(otos::scalar_register(1.0034), 0x03);
  EXPECT_EQ(otos::scalar_register(1.128), std::nullopt);
  EXPECT_EQ(otos::scalar_register(0.87), std::nullopt);
  EXPECT_EQ(otos::scalar_register(std::nan("")), std::nullopt);
}

TEST(OtosRegisters, APollIsStatusPositionAndVelocity) {
  std::array<std::uint8_t, otos::kPollBytes> bytes{};
  bytes[0] = otos::kStatusTilt | otos::kStatusOpticalTracking;
  otos::encode_raw({100, -200, 8192}, std::span<std::uint8_t, 6>(bytes.data() + 1, 6));
  otos::encode_raw({3000, -4000, -32768}, std::span<std::uint8_t, 6>(bytes.data() + 7, 6));
  const otos::Reading r = otos::decode_poll(bytes);
  EXPECT_EQ(r.status, 0x03);
  EXPECT_DOUBLE_EQ(r.position.x(), 100 * 10.0 / 32768.0);
  EXPECT_DOUBLE_EQ(r.position.y(), -200 * 10.0 / 32768.0);
  EXPECT_DOUBLE_EQ(r.heading, std::numbers::pi / 4.0);
  EXPECT_DOUBLE_EQ(r.velocity.x(), 3000 * 5.0 / 32768.0);
  EXPECT_DOUBLE_EQ(r.velocity.y(), -4000 * 5.0 / 32768.0);
  EXPECT_DOUBLE_EQ(r.rate, -2000.0 * std::numbers::pi / 180.0);
  EXPECT_TRUE(r.rate_saturated);
}

TEST(OtosRegisters, VelocityIsTurnedBackIntoTheUnitsFrameByItsHeading) {
  // A unit turned by h from its tracking frame, moving along its own x at
  // 0.3 m/s and its own y at -0.1 m/s, reports v_track = R(h) w; the
  // turn-back gives w again: w_x = c v_x + s v_y, w_y = -s v_x + c v_y.
  for (const double h : {0.0, 0.7, -2.0, 3.1}) {
    SCOPED_TRACE(h);
    const double c = std::cos(h), s = std::sin(h);
    otos::Reading r;
    r.heading = h;
    r.velocity = Vec2(c * 0.3 - s * -0.1, s * 0.3 + c * -0.1);
    const Vec2 w = otos::body_velocity(r);
    EXPECT_NEAR(w.x(), 0.3, 1e-15);
    EXPECT_NEAR(w.y(), -0.1, 1e-15);
    EXPECT_NEAR(w.x(), c * r.velocity.x() + s * r.velocity.y(), 1e-15);
  }
  // Through the registers: the error is bounded by their rounding, half an
  // LSB of velocity per axis and half an LSB of heading times the speed.
  OtosModelState model;
  const double h = 2.5;
  const Vec2 w(0.8, 0.25);
  model.set_triple(otos::kRegPosition, {Vec2::Zero(), h}, otos::kPositionScale);
  model.set_triple(otos::kRegVelocity, {rotation(h) * w, 0.0}, otos::kVelocityScale);
  const otos::Reading r = otos::decode_poll(std::span<const std::uint8_t, otos::kPollBytes>(
      model.regs.data() + otos::kRegStatus, otos::kPollBytes));
  const double bound =
      std::sqrt(2.0) * otos::kVelocityLsb / 2.0 + w.norm() * otos::kHeadingLsb / 2.0;
  EXPECT_LE((otos::body_velocity(r) - w).norm(), bound);
}

TEST(OtosRegisters, VelocityCountsAreTheTrapezoidRoundedWithTheRemainderCarried) {
  io::VelocityCounts counts(1e6);                             // 1 um a count
  EXPECT_EQ(counts.add(0.0, Vec2(0.1, -0.2)), Vec2::Zero());  // opens
  // (0.1 + 0.3) / 2 x 0.0049 s = 980 um; (-0.2 + -0.2) / 2 x 0.0049 = -980 um.
  EXPECT_EQ(counts.add(0.0049, Vec2(0.3, -0.2)), Vec2(980.0, -980.0));
  // 0.3 x 1.5e-6 s = 0.45 counts: rounds to 0, then the carried 0.45 + 0.45 = 0.9 to 1.
  EXPECT_EQ(counts.add(0.0049015, Vec2(0.3, 0.0)).x(), 0.0);
  EXPECT_EQ(counts.add(0.004903, Vec2(0.3, 0.0)).x(), 1.0);
  EXPECT_LE(counts.remainder().cwiseAbs().maxCoeff(), 0.5);
  counts.restart();
  EXPECT_EQ(counts.add(1.0, Vec2(5.0, 5.0)), Vec2::Zero());
}

// ------------------------------------------------------------------- units

struct FakeClock {
  double time = 100.0;  // s, not 0: the rows' clock is relative to the start
  io::OtosClock clock() {
    return {[this] { return time; }, [this](double s) { time += std::max(s, 1e-6); }};
  }
};

RobotConfig two_units() {
  return io::parse_config(
      "version: 1\n"
      "sensors:\n"
      "  - {name: o1, position: [0.1, 0.05], yaw: 0.3, cpi: 254000}\n"
      "  - {name: o2, position: [-0.08, -0.06], yaw: -2.0, cpi: 254000}\n",
      "robot.yaml");
}

struct Rig {
  FakeClock clock;
  std::vector<std::shared_ptr<OtosModelState>> models;
  std::vector<std::string> warnings;
  io::LiveHooks hooks;
  double stop_at = 1e9;  // s on the rows' clock
  double origin = 0.0;

  explicit Rig(int n) {
    for (int i = 0; i < n; ++i) {
      models.push_back(std::make_shared<OtosModelState>());
      models.back()->where = "model" + std::to_string(i + 1) + ":0x17";
    }
    hooks.warn = [this](const std::string& w) { warnings.push_back(w); };
  }
  std::vector<io::OtosLink> links(const RobotConfig& config) {
    std::vector<io::OtosLink> out;
    for (std::size_t i = 0; i < models.size(); ++i) {
      io::OtosDevice d;
      d.name = config.names[i];
      d.bus = {"model", otos::kDefaultAddress};
      d.sensor = static_cast<int>(i);
      out.push_back({d, std::make_unique<OtosModel>(models[i])});
    }
    return out;
  }
  std::unique_ptr<io::OtosReader> reader(const RobotConfig& config, io::OtosOptions options = {}) {
    hooks.stop = [this] { return clock.time - origin >= stop_at; };
    auto r = std::make_unique<io::OtosReader>(links(config), config, options, hooks, clock.clock());
    origin = clock.time;
    return r;
  }
  int count_warnings(const std::string& text) const {
    int n = 0;
    for (const auto& w : warnings) n += w.find(text) != std::string::npos;
    return n;
  }
};

TEST(OtosUnit, StartChecksTheProductIdAndSetsOffsetScalarsAndRotation) {
  auto state = std::make_shared<OtosModelState>();
  state->regs[otos::kRegLinearScalar] = 0x05;   // 1.005, left by someone
  state->regs[otos::kRegSignalProcess] = 0x0B;  // rotation off
  state->regs[otos::kRegOffset] = 0x44;         // an offset
  OtosModel model(state);
  double slept = 0.0;
  const io::OtosStart s = io::start_otos(model, {}, [&](double d) { slept += d; });
  ASSERT_TRUE(s.info) << s.error.message;
  EXPECT_DOUBLE_EQ(s.info->linear_scalar, 1.005);
  EXPECT_EQ(s.info->hardware_version, 0x10);
  EXPECT_EQ(state->regs[otos::kRegLinearScalar], 0x00);
  EXPECT_EQ(state->regs[otos::kRegAngularScalar], 0x00);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(state->regs[otos::kRegOffset + i], 0) << i;
  EXPECT_EQ(state->regs[otos::kRegSignalProcess], 0x0F);
  // The IMU calibration: 255 samples written, waited for (the model counts 64 a read).
  EXPECT_EQ(state->regs[otos::kRegImuCalibration], 0);
  EXPECT_GT(slept, 0.0);
  ASSERT_FALSE(state->writes.empty());
  EXPECT_EQ(state->writes.back().first, otos::kRegReset);  // tracking reset last

  state->regs[otos::kRegProductId] = 0x42;
  const io::OtosStart wrong = io::start_otos(model, {}, [](double) {});
  EXPECT_FALSE(wrong.info);
  EXPECT_EQ(wrong.error.message,
            "product ID 0x42, an OTOS reads 0x5f: another device at this address?");

  state->regs[otos::kRegProductId] = otos::kProductId;
  state->calibration_step = 0;  // never finishes
  const io::OtosStart stuck = io::start_otos(model, {}, [](double) {});
  EXPECT_FALSE(stuck.info);
  EXPECT_NE(stuck.error.message.find("IMU calibration did not finish in 0.86 s (255 samples left "
                                     "of 255)"),
            std::string::npos)
      << stuck.error.message;

  state->answering = false;
  const io::OtosStart silent = io::start_otos(model, {}, [](double) {});
  EXPECT_EQ(silent.error.error, EREMOTEIO);
  EXPECT_EQ(silent.error.message.rfind("does not answer (product ID: ", 0), 0u)
      << silent.error.message;
}

TEST(OtosReader, BadStartsAndOptionsAreRefusedWithTheUnitsName) {
  const RobotConfig config = two_units();
  {
    Rig rig(2);
    rig.models[1]->regs[otos::kRegProductId] = 0x00;
    EXPECT_EQ(error_of([&] { rig.reader(config); }),
              "o2 (model2:0x17): product ID 0x00, an OTOS reads 0x5f: another device at this "
              "address?");
  }
  {
    Rig rig(2);
    rig.models[0]->answering = false;
    EXPECT_EQ(error_of([&] { rig.reader(config); }).rfind("o1 (model1:0x17): does not answer", 0),
              0u);
  }
  {
    Rig rig(2);
    rig.models[1]->where = "model1:0x17";  // both on one bus and address
    EXPECT_NE(error_of([&] { rig.reader(config); }).find("a second unit at the same bus"),
              std::string::npos);
  }
  {
    Rig rig(1);
    io::OtosOptions options;
    options.rate = 500;
    EXPECT_EQ(error_of([&] { rig.reader(config, options); }),
              "OTOS options: rate: must be 25 to 416.7 Hz (the unit's loop), is 500");
  }
  // A device that is no adapter, and one that does not exist.
  EXPECT_EQ(
      error_of([] { io::I2cDev("/dev/null", 0x17); }).rfind("/dev/null: not an I2C adapter", 0),
      0u);
  EXPECT_EQ(error_of([] { io::I2cDev("/nonexistent/i2c-9", 0x17); }),
            "/nonexistent/i2c-9: cannot open (No such file or directory); is the i2c-dev module "
            "loaded (sudo modprobe i2c-dev)? see docs/hardware.md");
  EXPECT_EQ(io::parse_i2c_address("/dev/i2c-1", 0x17).address, 0x17);
  EXPECT_EQ(io::parse_i2c_address("/dev/i2c-1:0x18", 0x17).address, 0x18);
  EXPECT_EQ(io::parse_i2c_address("/dev/i2c-1:23", 0x17).address, 23);
  EXPECT_EQ(error_of([] { io::parse_i2c_address("/dev/i2c-1:0x80", 0x17); }),
            "/dev/i2c-1:0x80: '0x80' is not a 7-bit I2C address (0x03 to 0x77, decimal or 0x "
            "hex)");
  EXPECT_EQ(error_of([] { io::parse_i2c_address(":0x17", 0x17); }),
            ":0x17: no device path (/dev/i2c-N)");
}

// A robot with a constant twist, two units on it, read through the models
// into the pipeline as `moa live --otos` runs it (LiveRunSource, run_loop):
// every epoch's least-squares twist is the truth within the bound the
// registers' rounding gives, propagated through the least squares.
TEST(OtosReader, ASimulatedRobotsTwistComesBackWithinTheRegistersQuantisation) {
  const RobotConfig config = two_units();
  const Twist2 truth{Vec2(0.4, -0.15), 1.3};  // 4 s: 5.2 rad, the heading wraps
  Rig rig(2);
  for (int i = 0; i < 2; ++i) {
    drive_otos_model(*rig.models[static_cast<std::size_t>(i)], config.array[i], truth,
                     [&rig] { return rig.clock.time; });
  }
  rig.stop_at = 4.0;
  auto reader = rig.reader(config);
  io::LiveRunSource input(*reader, config.array.size(), "OTOS units");
  input.add_gyro(*reader);
  const OdometryOptions options =
      io::resolve_odometry_options(OdometryOptions{}, "ls", {}, true, config, "robot.yaml");
  std::vector<Twist2> twists;
  io::RunCallbacks callbacks;
  callbacks.on_step = [&](const OdometryStep& step) {
    twists.push_back(step.estimate.estimate.twist);
  };
  const io::OdometryRun run =
      io::run_loop(config, "robot.yaml", options, input, "OTOS units", callbacks);
  EXPECT_TRUE(rig.warnings.empty()) << rig.warnings.front();
  EXPECT_GT(run.imu_rows, 700u);  // the first unit's gyro, a sample a poll after its first
  ASSERT_GT(twists.size(), 390u);

  // Per unit and epoch, the point velocity's error: half an LSB of velocity
  // per axis; an LSB of heading times the speed (the turn-back: half for
  // the rounding, another half where +pi saturates to 32767); and three
  // counts per axis over the epoch (the carried remainders at the epoch's
  // two ends, each at most half a count, and the fractions of the rows that
  // straddle them, each at most a count).
  const double k = config.array[0].counts_per_metre();
  const double period = 1.0 / options.rate;
  Mat<4, 3> a;
  double speed = 0.0;
  for (int i = 0; i < 2; ++i) {
    a.block<2, 3>(2 * i, 0) = config.array[i].point_jacobian();
    speed = std::max(speed, (config.array[i].point_jacobian() * truth.vector()).norm());
  }
  const double per_unit = std::sqrt(2.0) * otos::kVelocityLsb / 2.0 + speed * otos::kHeadingLsb +
                          std::sqrt(2.0) * 3.0 / (k * period);
  // |delta twist| <= |A^+| |delta u|, |delta u| <= sqrt(2) per_unit (two units).
  // |A^+| = 1 / sigma_min(A) = 1 / sqrt(lambda_min(A^T A)).
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(a.transpose() * a);
  const double bound = std::sqrt(2.0) * per_unit / std::sqrt(eig.eigenvalues().minCoeff());
  double worst = 0.0;
  for (std::size_t e = 1; e + 1 < twists.size(); ++e) {  // first and last: partial rows
    worst = std::max(worst, (twists[e].vector() - truth.vector()).norm());
  }
  EXPECT_LE(worst, bound);
  EXPECT_GT(worst, 0.0);  // the quantisation is there: the test can fail
  // 200 Hz, two units, 4 s.
  EXPECT_NEAR(static_cast<double>(reader->stats(0).rows), 800.0, 3.0);
  EXPECT_EQ(reader->stats(1).rows, reader->stats(0).rows);
}

// One unit and its gyro through the consensus (one sensor takes its
// rotation from the gyro): the rotation rate is the gyro's, within its
// register's rounding.
TEST(OtosReader, OneUnitsGyroGivesTheRotation) {
  const RobotConfig config = io::parse_config(
      "version: 1\n"
      "sensors:\n"
      "  - {name: o1, position: [0.05, 0.02], yaw: 1.0, cpi: 254000}\n",
      "robot.yaml");
  const Twist2 truth{Vec2(0.3, 0.0), -0.8};
  Rig rig(1);
  drive_otos_model(*rig.models[0], config.array[0], truth, [&rig] { return rig.clock.time; });
  rig.stop_at = 6.0;
  auto reader = rig.reader(config);
  io::LiveRunSource input(*reader, config.array.size(), "OTOS o1");
  input.add_gyro(*reader);
  const OdometryOptions options =
      io::resolve_odometry_options(OdometryOptions{}, "consensus", {}, true, config, "robot.yaml");
  std::vector<Twist2> twists;
  io::RunCallbacks callbacks;
  callbacks.on_step = [&](const OdometryStep& step) {
    twists.push_back(step.estimate.estimate.twist);
  };
  const io::OdometryRun run =
      io::run_loop(config, "robot.yaml", options, input, "OTOS o1", callbacks);
  EXPECT_GT(run.imu_rows, 1000u);
  ASSERT_GT(twists.size(), 590u);
  // The last second, the motion prior's start-up behind: the gyro rows are
  // the rate register rounded (half an LSB), the mean of the epoch's.
  double worst_omega = 0.0;
  for (std::size_t e = twists.size() - 100; e + 1 < twists.size(); ++e) {
    worst_omega = std::max(worst_omega, std::abs(twists[e].omega - truth.omega));
  }
  EXPECT_LE(worst_omega, otos::kRateLsb / 2.0 + 1e-9);
}

TEST(OtosReader, AUnitThatStopsAnsweringIsLeftOutAndTakenBackNeverTheRunsEnd) {
  const RobotConfig config = two_units();
  const Twist2 truth{Vec2(0.2, 0.0), 0.0};
  Rig rig(2);
  for (int i = 0; i < 2; ++i) {
    drive_otos_model(*rig.models[static_cast<std::size_t>(i)], config.array[i], truth,
                     [&rig] { return rig.clock.time; });
  }
  auto reader = rig.reader(config);
  std::vector<SensorRow> rows;
  const auto read_until = [&](double t) {
    while (rig.clock.time - rig.origin < t) {
      const auto row = reader->next();
      ASSERT_TRUE(row);
      rows.push_back(*row);
    }
  };
  read_until(0.5);
  rig.models[1]->answering = false;
  read_until(1.0);
  EXPECT_FALSE(reader->stats(1).answering);
  EXPECT_EQ(reader->answering(), 1);
  EXPECT_EQ(reader->stats(1).silences, 1u);
  EXPECT_EQ(rig.count_warnings("o2 (model2:0x17): stopped answering (Remote I/O error)"), 1);
  // Silent: lift rows of zero counts at every poll, o1 goes on.
  std::size_t lift = 0, o1_after = 0;
  for (const SensorRow& r : rows) {
    if (r.t < 0.55) continue;
    if (r.sensor == 1) {
      EXPECT_EQ(r.counts, Vec2::Zero());
      lift += (r.flags & kFlagLift) != 0;
    } else {
      ++o1_after;
      EXPECT_EQ(r.flags, 0);
    }
  }
  EXPECT_GT(lift, 80u);
  EXPECT_GT(o1_after, 80u);
  // It comes back with another part at its address: refused, still silent.
  rig.models[1]->answering = true;
  rig.models[1]->regs[otos::kRegProductId] = 0x31;
  read_until(1.5);
  EXPECT_FALSE(reader->stats(1).answering);
  // The OTOS again: taken back, started again (scalars 1, offset 0), counts resume.
  rig.models[1]->regs[otos::kRegProductId] = otos::kProductId;
  rig.models[1]->regs[otos::kRegOffset] = 9;  // a power cycle would lose moa's settings
  rows.clear();
  read_until(2.0);
  EXPECT_TRUE(reader->stats(1).answering);
  EXPECT_EQ(rig.models[1]->regs[otos::kRegOffset], 0);
  EXPECT_EQ(rig.count_warnings("o2 (model2:0x17): answers again after"), 1);
  double counted = 0.0;
  for (const SensorRow& r : rows) {
    if (r.sensor == 1 && !(r.flags & kFlagLift)) counted += r.counts.norm();
  }
  EXPECT_GT(counted, 0.0);
  for (std::size_t i = 1; i < rows.size(); ++i) EXPECT_GE(rows[i].t, rows[i - 1].t);
}

TEST(OtosReader, StatusBitsFlagTheRowsAndAreSaidOncePerUnit) {
  const RobotConfig config = two_units();
  Rig rig(2);
  const Twist2 truth{Vec2(0.2, 0.1), 0.5};
  for (int i = 0; i < 2; ++i) {
    drive_otos_model(*rig.models[static_cast<std::size_t>(i)], config.array[i], truth,
                     [&rig] { return rig.clock.time; });
  }
  // Unit 1 loses optical tracking, unit 2 is tilted and then its IMU faults,
  // each for a while.
  const auto status_between = [&rig](std::uint8_t bits, double from, double to,
                                     std::function<void(OtosModelState&)> drive) {
    return [&rig, bits, from, to, drive](OtosModelState& s) {
      drive(s);
      const double t = rig.clock.time - rig.origin;
      s.regs[otos::kRegStatus] = t >= from && t < to ? bits : 0;
    };
  };
  rig.models[0]->before_poll =
      status_between(otos::kStatusOpticalTracking, 0.2, 0.4, rig.models[0]->before_poll);
  rig.models[1]->before_poll =
      status_between(otos::kStatusTilt, 0.2, 0.3, rig.models[1]->before_poll);
  auto reader = rig.reader(config);
  std::size_t lift_rows = 0, low_squal = 0;
  std::size_t gyro = 0;
  while (rig.clock.time - rig.origin < 0.6) {
    const auto row = reader->next();
    ASSERT_TRUE(row);
    gyro += reader->take_gyro().size();
    if (row->sensor == 0 && (row->flags & kFlagLift)) ++lift_rows;
    if (row->sensor == 1 && row->squal == 0) ++low_squal;
    if (row->sensor == 0) {
      EXPECT_FALSE(row->squal);
    }
  }
  EXPECT_NEAR(static_cast<double>(lift_rows), 40.0, 1.0);  // 0.2 s at 200 Hz
  EXPECT_NEAR(static_cast<double>(low_squal), 20.0, 1.0);
  EXPECT_EQ(reader->stats(0).tracking_lost, lift_rows);
  EXPECT_EQ(reader->stats(1).tilt, low_squal);
  EXPECT_EQ(rig.count_warnings("o1 (model1:0x17): optical tracking unreliable at t = 0.20"), 1);
  EXPECT_EQ(rig.count_warnings("o2 (model2:0x17): tilted beyond its threshold"), 1);
  EXPECT_EQ(rig.warnings.size(), 2u);
  EXPECT_GT(gyro, 100u);

  // The first unit's IMU faults: its gyro samples are withheld, its rows weighed less.
  rig.models[0]->before_poll =
      status_between(otos::kStatusImuFault, 0.0, 1e9, rig.models[0]->before_poll);
  for (int i = 0; i < 40; ++i) {
    const auto row = reader->next();
    ASSERT_TRUE(row);
    if (row->sensor == 0) {
      EXPECT_EQ(row->squal, 0);
    }
  }
  EXPECT_TRUE(reader->take_gyro().empty());
  EXPECT_GE(reader->stats(0).imu_fault, 19u);
  EXPECT_EQ(rig.count_warnings("its IMU reports a fault"), 1);
}

TEST(OtosReader, CorruptAndImpossibleReadsAreDroppedAndTheirMotionKept) {
  RobotConfig config = two_units();
  Rig rig(1);
  const Twist2 truth{Vec2(0.5, 0.0), 0.0};
  drive_otos_model(*rig.models[0], config.array[0], truth, [&rig] { return rig.clock.time; });
  int poll = 0;
  const auto drive = rig.models[0]->before_poll;
  rig.models[0]->before_poll = [&poll, drive](OtosModelState& s) {
    drive(s);
    s.regs[otos::kRegStatus] = 0;
    ++poll;
    if (poll == 20) s.regs[otos::kRegStatus] = 0xFF;  // a bus of ones
    if (poll == 40) s.set_triple(otos::kRegVelocity, {Vec2(4.9, -4.9), 0.0}, otos::kVelocityScale);
  };
  config.names.resize(1);
  config.array = SensorArray{config.array[0]};
  auto reader = rig.reader(config);
  Vec2 sum = Vec2::Zero();
  double t_first = -1.0, t_last = 0.0;
  while (poll < 100) {
    const auto row = reader->next();
    ASSERT_TRUE(row);
    if (t_first < 0.0) t_first = row->t;
    t_last = row->t;
    sum += row->counts;
  }
  EXPECT_EQ(reader->stats(0).corrupt, 1u);
  // The spike and the read after it (it differs from the spike as much).
  EXPECT_EQ(reader->stats(0).implausible, 2u);
  EXPECT_EQ(reader->stats(0).rows, 97u);  // 100 polls, 3 dropped
  EXPECT_EQ(rig.count_warnings("status 0xff has reserved bits set"), 1);
  EXPECT_EQ(rig.count_warnings("beyond its accelerometer's full scale: the read is dropped"), 1);
  // The motion over the dropped reads is in the next row's interval: the sum
  // is the distance, within the registers' rounding and a count.
  const Vec2 w = rotation(config.array[0].yaw).transpose() * truth.v;
  const Vec2 expected = w * (t_last - t_first) * config.array[0].counts_per_metre();
  const double bound = (std::sqrt(2.0) * otos::kVelocityLsb / 2.0) * (t_last - t_first) *
                           config.array[0].counts_per_metre() +
                       1.0;
  EXPECT_LE((sum - expected).norm(), bound);
}

TEST(OtosCli, FlagsAreCheckedWithPreciseErrors) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("moa-otos-cli-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string config = (dir / "robot.yaml").string();
  const auto init = run_moa(
      "config init --preset OTOS --sensor o1=0.1,0,0 --sensor o2=-0.1,0,180 "
      "--out " +
      config);
  ASSERT_EQ(init.exit_code, 0) << init.err;
  const auto live = [&](const std::string& flags) {
    return run_moa("live --config " + config + " --duration 1 " + flags);
  };
  auto r = live("--otos o3=/dev/i2c-1");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--otos o3=/dev/i2c-1: no sensor 'o3' in " + config), std::string::npos)
      << r.err;
  r = live("--otos /dev/i2c-1:0x99");
  EXPECT_NE(r.err.find("--otos /dev/i2c-1:0x99: '0x99' is not a 7-bit I2C address"),
            std::string::npos)
      << r.err;
  r = live("--otos /nonexistent/i2c-7");
  EXPECT_EQ(r.exit_code, 3);  // a file that cannot be opened, as a --mouse or --serial
  EXPECT_NE(r.err.find("o1: /nonexistent/i2c-7: cannot open (No such file or directory)"),
            std::string::npos)
      << r.err;
  r = live("--otos /dev/null");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("o1: /dev/null: not an I2C adapter"), std::string::npos) << r.err;
  r = live("--otos /dev/i2c-1 --otos /dev/i2c-2 --otos /dev/i2c-3");
  EXPECT_NE(r.err.find("--otos /dev/i2c-3: no NAME= and " + config + " has only 2 sensors"),
            std::string::npos)
      << r.err;
  r = live("--otos o1=/dev/i2c-1 --otos o1=/dev/i2c-2");
  EXPECT_NE(r.err.find("sensor 'o1' given twice"), std::string::npos) << r.err;
  r = live("--otos /dev/i2c-1 --otos-rate 1000");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("--otos-rate"), std::string::npos) << r.err;
  r = live("--otos /dev/i2c-1 --serial /dev/ttyACM0");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("excludes"), std::string::npos) << r.err;
  std::filesystem::remove_all(dir);
}

TEST(OtosCli, ConfigInitPresetTakesOneUnitAndWritesItsGyro) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("moa-otos-init-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::filesystem::path out = dir / "robot.yaml";
  const auto r = run_moa("config init --preset OTOS --sensor o1=0.05,0,90 --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const RobotConfig config = io::read_config(out);
  ASSERT_EQ(config.array.size(), 1);
  EXPECT_EQ(config.array[0].cpi, 254000.0);
  EXPECT_FALSE(config.array[0].mirrored);
  ASSERT_TRUE(config.imu);
  EXPECT_NEAR(config.imu->max_rate, 2000.0 * std::numbers::pi / 180.0, 1e-12);
  std::ifstream in(out);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("254000 cpi: 0.1 um a count"), std::string::npos) << text;
  // Any cpi will do for a velocity sensor; a mouse preset still needs two sensors.
  EXPECT_EQ(run_moa("config init --preset OTOS --cpi 1000 --sensor o1=0,0,0 --force --out " +
                    out.string())
                .exit_code,
            0);
  const auto mouse =
      run_moa("config init --preset PMW3360 --sensor m1=0,0,0 --force --out " + out.string());
  EXPECT_NE(mouse.err.find("--sensor: give at least 2 sensors"), std::string::npos) << mouse.err;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace moa::test
