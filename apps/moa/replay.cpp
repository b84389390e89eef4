#include "replay.hpp"

#include <fmt/core.h>

#include <deque>
#include <optional>
#include <vector>

#include "moa/core/dead_reckoner.hpp"
#include "moa/core/consensus.hpp"
#include "moa/core/ekf.hpp"
#include "moa/core/estimate.hpp"
#include "moa/io/error.hpp"
#include "moa/core/sekimori.hpp"
#include "moa/core/synchronise.hpp"
#include "moa/core/wheels.hpp"

namespace moa::cli {
namespace {

template <class T>
T get_or_throw(std::variant<T, GeometryError> built) {
  if (const auto* e = std::get_if<GeometryError>(&built)) throw io::Error(describe(*e));
  return std::get<T>(std::move(built));
}

}  // namespace

TrajectoryError replay(const sim::SimLog& log, const io::RobotConfig& config,
                       const ReplayOptions& options) {
  const SensorArray& array = config.array;
  const int n = array.size();
  const SensorMask mask = options.mask & all_sensors(n);
  const double period = 1.0 / options.rate;
  const double t0 = log.mice.empty() ? 0.0 : log.mice.front().t;

  std::vector<StampedPose> truth;
  truth.reserve(log.truth.size());
  for (const auto& r : log.truth) truth.push_back({r.t, r.pose});
  TrajectoryErrorAccumulator errors(truth);

  // Counts and, in a twin synchroniser, the simulator's fault bits per epoch.
  Synchroniser counts(n, t0, {period, 0.05});
  Synchroniser faults(n, t0, {period, 0.05});
  WheelAverager wheels;
  std::size_t next_wheel = 0, next_fix = 0;

  std::optional<LsEstimator> ls;
  if (options.method == ReplayMethod::kLs)
    ls = get_or_throw(LsEstimator::create(array, mask, period));
  std::optional<SekimoriEstimator> sekimori;
  if (options.method == ReplayMethod::kSekimori)
    sekimori = get_or_throw(SekimoriEstimator::create(array));
  std::optional<ConsensusEstimator> consensus;
  if (options.method == ReplayMethod::kConsensus) {
    consensus = get_or_throw(ConsensusEstimator::create(array));
  }
  SubsetSolver oracle(array);
  NoiseModel noise(array);
  PointMeasurements points;
  std::array<std::uint8_t, kMaxSensors> noise_flags{};

  DeadReckoner reckoner;
  std::optional<PoseEkf> ekf;
  if (options.fuse_camera) {
    ekf.emplace(t0, Pose2{}, Eigen::Matrix3d(Eigen::Vector3d(1e-8, 1e-8, 1e-8).asDiagonal()));
  }
  std::deque<ArraySample> fault_samples;  // epochs whose counts are not out yet
  Twist2 last;

  const auto wheel_twist = [&](double a, double b) -> std::optional<Twist2> {
    while (next_wheel < log.wheels.size() && !wheels.covers(b) && !wheels.full()) {
      wheels.push(log.wheels[next_wheel].t, log.wheels[next_wheel].twist);
      ++next_wheel;
    }
    return wheels.average(a, b);
  };

  const auto on_sample = [&](const ArraySample& s) {
    const auto w = wheel_twist(s.t - s.dt, s.t);
    Twist2 x;
    Eigen::Matrix3d cov = Eigen::Matrix3d::Identity() * 1e-4;
    switch (options.method) {
      case ReplayMethod::kWheels:
        x = w.value_or(Twist2{});
        break;
      case ReplayMethod::kLs:
        x = ls->estimate(s)->twist;
        cov = ls->estimate(s)->covariance;
        break;
      case ReplayMethod::kSekimori: {
        const auto e = sekimori->estimate(s, w);
        x = e->estimate.twist;
        cov = e->estimate.covariance;
        break;
      }
      case ReplayMethod::kConsensus: {
        const auto e = consensus->estimate(s, w);
        x = e->estimate.twist;
        cov = e->estimate.covariance;
        break;
      }
      case ReplayMethod::kOracle: {
        const ArraySample& f = fault_samples.front();
        SensorMask good = 0;
        for (int i = 0; i < n; ++i) {
          if (contains(mask, i) && f.flags[static_cast<std::size_t>(i)] == 0)
            good |= SensorMask{1} << i;
        }
        noise.measure(s, last, points, noise_flags);
        const auto fit = oracle.fit(good, points);
        if (fit) {
          x = fit->twist;
          cov = fit->covariance;
        } else {
          x = w.value_or(last);
        }
        break;
      }
    }
    if (!fault_samples.empty()) fault_samples.pop_front();
    last = x;
    if (ekf) {
      ekf->predict(s.t, x, cov, s.dt);
      while (next_fix < log.camera.size() && log.camera[next_fix].t_arrival <= s.t) {
        const auto& fix = log.camera[next_fix++];
        ekf->update_position(fix.t, fix.position,
                             Eigen::Matrix2d::Identity() * fix.sigma * fix.sigma);
      }
      errors.add(s.t, ekf->pose());
    } else {
      errors.add(s.t, reckoner.step(x, s.dt));
    }
  };

  // The twin is fed each row first, so an epoch's faults are queued before
  // its counts reach on_sample.
  const auto on_faults = [&](const ArraySample& s) { fault_samples.push_back(s); };
  for (const auto& r : log.mice) {
    const SensorRow faults_row{r.t, r.sensor, {0.0, 0.0}, std::nullopt, r.row.faults};
    if (faults.push(faults_row, on_faults)) throw io::Error("simulated log: invalid row");
    SensorRow row{r.t, r.sensor, r.row.counts.cast<double>(), r.row.squal, r.row.flags};
    if (counts.push(row, on_sample)) throw io::Error("simulated log: invalid row");
  }
  const double t_end = log.mice.empty() ? t0 : log.mice.back().t;
  faults.finish(t_end, on_faults);
  counts.finish(t_end, on_sample);
  return errors.result();
}

}  // namespace moa::cli
