#include "pipeline.hpp"

#include <fmt/core.h>

#include <cmath>
#include <variant>

#include "moa/core/dead_reckoner.hpp"
#include "moa/core/consensus.hpp"
#include "moa/core/ekf.hpp"
#include "moa/core/estimate.hpp"
#include "moa/io/error.hpp"
#include "moa/core/sekimori.hpp"
#include "moa/core/wheels.hpp"

namespace moa::cli {
namespace {

template <class Estimator>
Estimator built_or_throw(std::variant<Estimator, GeometryError> built, const std::string& path) {
  if (const auto* error = std::get_if<GeometryError>(&built)) {
    throw io::Error(fmt::format("{}: {}", path, describe(*error)));
  }
  return std::get<Estimator>(std::move(built));
}

class LsSource : public TwistSource {
 public:
  explicit LsSource(LsEstimator est) : est_(std::move(est)) {}
  std::optional<RobustEstimate> estimate(const ArraySample& sample,
                                         const std::optional<Twist2>&) override {
    const auto e = est_.estimate(sample);
    if (!e) return std::nullopt;
    RobustEstimate out;
    out.estimate = *e;
    return out;
  }

 private:
  LsEstimator est_;
};

template <class Estimator>
class RobustSource : public TwistSource {
 public:
  explicit RobustSource(Estimator est) : est_(std::move(est)) {}
  std::optional<RobustEstimate> estimate(const ArraySample& sample,
                                         const std::optional<Twist2>& wheels) override {
    return est_.estimate(sample, wheels);
  }

 private:
  Estimator est_;
};

std::string sd(double variance) {
  return fmt::format("{:.6g}", std::sqrt(std::max(variance, 0.0)));
}

}  // namespace

std::unique_ptr<TwistSource> TwistSource::create(const PipelineOptions& options,
                                                 const SensorArray& array,
                                                 const std::string& config_path) {
  const std::string& name = options.estimator;
  const double period = 1.0 / options.rate;
  if (name == "ls") {
    return std::make_unique<LsSource>(
        built_or_throw(LsEstimator::create(array, all_sensors(array.size()), period), config_path));
  }
  if (name == "sekimori") {
    return std::make_unique<RobustSource<SekimoriEstimator>>(
        built_or_throw(SekimoriEstimator::create(array, options.sekimori), config_path));
  }
  if (name == "consensus") {
    return std::make_unique<RobustSource<ConsensusEstimator>>(
        built_or_throw(ConsensusEstimator::create(array, options.consensus), config_path));
  }
  throw io::Error(fmt::format("unknown estimator '{}' (ls, sekimori, consensus)", name));
}

struct Pipeline::Impl {
  Synchroniser sync;
  std::unique_ptr<TwistSource> estimator;
  std::unique_ptr<io::WheelsReader> wheels_reader;
  WheelAverager wheels;
  bool wheels_done = false;
  DeadReckoner reckoner;
  Sink sink;
  std::unique_ptr<io::CameraReader> camera;
  PipelineOptions options;
  std::optional<PoseEkf> ekf;
  std::optional<io::CameraRow> pending_fix;
  FixCounts fixes;
  double t0 = 0.0;

  Eigen::Matrix2d fix_covariance(const io::CameraRow& row) const {
    const Eigen::Vector2d sd =
        row.sigma ? *row.sigma : Eigen::Vector2d::Constant(options.camera_sigma);
    return sd.cwiseAbs2().asDiagonal();
  }

  /// The EKF starts at the given pose, or at the first fix's position.
  void start_filter() {
    Eigen::Matrix3d p0 = Eigen::Vector3d(1e-8, 1e-8, 1e-8).asDiagonal();
    Pose2 initial = options.initial.value_or(Pose2{});
    if (!options.initial) {
      pending_fix = camera->next();
      if (pending_fix) {
        initial.t = pending_fix->position;
        p0.topLeftCorner<2, 2>() = fix_covariance(*pending_fix);
        p0(2, 2) = 1e-4;
        pending_fix.reset();  // it made the initial position
      }
    }
    ekf.emplace(t0, initial, p0);
  }

  /// Applies every fix that has arrived by t (capture time + latency).
  void apply_fixes(double t) {
    while (true) {
      if (!pending_fix) pending_fix = camera->next();
      if (!pending_fix || pending_fix->t + options.camera_latency > t) return;
      const io::CameraRow& f = *pending_fix;
      FixResult result;
      if (f.theta) {
        Eigen::Matrix3d r = Eigen::Matrix3d::Zero();
        r.topLeftCorner<2, 2>() = fix_covariance(f);
        r(2, 2) = options.camera_heading_sigma * options.camera_heading_sigma;
        result = ekf->update_pose(f.t, {f.position.x(), f.position.y(), *f.theta}, r);
      } else {
        result = ekf->update_position(f.t, f.position, fix_covariance(f));
      }
      switch (result) {
        case FixResult::kApplied:
          ++fixes.applied;
          break;
        case FixResult::kRejected:
          ++fixes.rejected;
          break;
        case FixResult::kTooOld:
          ++fixes.too_old;
          break;
        case FixResult::kFuture:
          return;  // keep it until the filter has reached its time
        case FixResult::kInvalid:
          ++fixes.invalid;
          break;
      }
      pending_fix.reset();
    }
  }

  void step(const ArraySample& sample, const RobustEstimate& estimate, std::size_t& samples) {
    if (ekf) {
      ekf->predict(sample.t, estimate.estimate.twist, estimate.estimate.covariance, sample.dt);
      apply_fixes(sample.t);
      sink(PipelineStep{sample, estimate, ekf->pose(), &ekf->covariance()});
    } else {
      sink(PipelineStep{sample, estimate, reckoner.step(estimate.estimate.twist, sample.dt),
                        nullptr});
    }
    ++samples;
  }

  std::optional<Twist2> wheel_twist(double a, double b) {
    if (!wheels_reader) return std::nullopt;
    while (!wheels_done && !wheels.covers(b) && !wheels.full()) {
      const auto row = wheels_reader->next();
      if (!row) {
        wheels_done = true;
        break;
      }
      wheels.push(row->t, row->twist);
    }
    return wheels.average(a, b);
  }
};

Pipeline::Pipeline(const io::RobotConfig& config, const std::string& config_path, double t0,
                   const PipelineOptions& options, std::unique_ptr<io::WheelsReader> wheels,
                   std::unique_ptr<io::CameraReader> camera, Sink sink)
    : t_last_(t0) {
  const double period = 1.0 / options.rate;
  impl_ = std::unique_ptr<Impl>(new Impl{
      Synchroniser(config.array.size(), t0, {period, options.max_row_interval, options.max_gap}),
      TwistSource::create(options, config.array, config_path), std::move(wheels), WheelAverager{},
      false, DeadReckoner(options.initial.value_or(Pose2{})), std::move(sink), std::move(camera),
      options, std::nullopt, std::nullopt, FixCounts{}, t0});
  if (impl_->camera) impl_->start_filter();
}

const FixCounts& Pipeline::fixes() const { return impl_->fixes; }

Pipeline::~Pipeline() = default;

void Pipeline::push(const SensorRow& row, const std::string& where) {
  Impl& s = *impl_;
  const auto on_sample = [&](const ArraySample& sample) {
    const auto wheels = s.wheel_twist(sample.t - sample.dt, sample.t);
    const auto estimate = s.estimator->estimate(sample, wheels);
    if (!estimate) {
      throw io::Error(fmt::format("{}: sample at t = {} s has no valid interval", where, sample.t));
    }
    s.step(sample, *estimate, samples_);
  };
  if (const auto error = s.sync.push(row, on_sample)) {
    throw io::Error(fmt::format("{}: row at t = {} s: {}", where, row.t, describe(*error)));
  }
  t_last_ = row.t;
}

void Pipeline::finish() {
  Impl& s = *impl_;
  s.sync.finish(t_last_, [&](const ArraySample& sample) {
    const auto wheels = s.wheel_twist(sample.t - sample.dt, sample.t);
    const auto estimate = s.estimator->estimate(sample, wheels);
    if (!estimate) return;  // a zero-length tail carries no motion
    s.step(sample, *estimate, samples_);
  });
}

std::vector<std::string> odometry_extra_columns(bool fused) {
  std::vector<std::string> columns{"sd_vx", "sd_vy", "sd_omega", "source", "used", "excluded"};
  if (fused) columns.insert(columns.end(), {"pxx", "pxy", "pyy", "ptt"});
  return columns;
}

void odometry_extra_values(const PipelineStep& step, const io::RobotConfig& config,
                           std::vector<std::string>& out) {
  const auto& e = step.estimate;
  out.resize(step.pose_covariance ? 10 : 6);
  if (const Eigen::Matrix3d* p = step.pose_covariance) {
    out[6] = fmt::format("{:.6g}", (*p)(0, 0));
    out[7] = fmt::format("{:.6g}", (*p)(0, 1));
    out[8] = fmt::format("{:.6g}", (*p)(1, 1));
    out[9] = fmt::format("{:.6g}", (*p)(2, 2));
  }
  out[0] = sd(e.estimate.covariance(0, 0));
  out[1] = sd(e.estimate.covariance(1, 1));
  out[2] = sd(e.estimate.covariance(2, 2));
  out[3] = describe(e.source);
  out[4].clear();
  out[5].clear();
  for (int i = 0; i < config.array.size(); ++i) {
    const auto u = static_cast<std::size_t>(i);
    if (contains(e.estimate.used, i)) {
      if (!out[4].empty()) out[4] += '+';
      out[4] += config.names[u];
    } else {
      if (!out[5].empty()) out[5] += ';';
      out[5] += config.names[u] + ':' + describe(e.excluded[u]);
      const auto f = e.noise_flags[u];
      if (f & kNoiseOverSpeed) out[5] += "/over-speed";
      if (f & kNoiseLowSqual) out[5] += "/low-squal";
      if (f & kNoiseOverflow) out[5] += "/overflow";
    }
  }
}

}  // namespace moa::cli
