// The dead-reckoning pipeline shared by `moa odometry` (files) and live
// input: frames -> Synchroniser -> estimator (+ wheels) -> DeadReckoner ->
// odometry rows. One path for every source, streamed, memory flat.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "moa/core/array.hpp"
#include "moa/core/consensus.hpp"
#include "moa/io/config.hpp"
#include "moa/io/log.hpp"
#include "moa/core/sekimori.hpp"
#include "moa/core/fallback.hpp"
#include "moa/core/noise_model.hpp"
#include "moa/core/synchronise.hpp"

namespace moa::cli {

struct PipelineOptions {
  std::string estimator = "consensus";  ///< ls | sekimori | consensus
  double rate = 100.0;                  ///< Hz, epochs
  double max_row_interval = 0.05;       ///< s
  double max_gap = 3600.0;              ///< s, longest silence of all sensors
  std::optional<Pose2> initial;        ///< world_T_robot at t0; default: identity, or the first fix
  bool fuse_camera = false;            ///< EKF with camera.csv fixes
  double camera_latency = 0.0;         ///< s from capture (camera.csv t) to arrival
  double camera_sigma = 0.005;         ///< m, fix sd when camera.csv has no sx, sy
  double camera_heading_sigma = 0.02;  ///< rad, when camera.csv has theta
  SekimoriOptions sekimori;            ///< E_th, r_th of the voting (sekimori.hpp)
  ConsensusOptions consensus;          ///< chi-square alpha, noise model (consensus.hpp)
};

/// Counts of what happened to the camera fixes.
struct FixCounts {
  std::size_t applied = 0, rejected = 0, too_old = 0, invalid = 0;
};

/// One output epoch of the pipeline.
struct PipelineStep {
  const ArraySample& sample;
  const RobustEstimate& estimate;
  const Pose2& pose;
  const Eigen::Matrix3d* pose_covariance;  ///< with --fuse-camera, else null
};

/// The estimator chosen by name behind one interface.
class TwistSource {
 public:
  virtual ~TwistSource() = default;
  virtual std::optional<RobustEstimate> estimate(const ArraySample& sample,
                                                 const std::optional<Twist2>& wheels) = 0;
  /// Throws io::Error naming `config_path` when the geometry is refused.
  static std::unique_ptr<TwistSource> create(const PipelineOptions& options,
                                             const SensorArray& array,
                                             const std::string& config_path);
};

class Pipeline {
 public:
  using Sink = std::function<void(const PipelineStep&)>;
  /// `wheels` and `camera` may be null (no wheels.csv, no fusion).
  Pipeline(const io::RobotConfig& config, const std::string& config_path, double t0,
           const PipelineOptions& options, std::unique_ptr<io::WheelsReader> wheels,
           std::unique_ptr<io::CameraReader> camera, Sink sink);
  ~Pipeline();

  /// Feeds one row; throws io::Error on an invalid row (`where` names it).
  void push(const SensorRow& row, const std::string& where);
  /// Flushes the epochs up to the last row's time.
  void finish();
  std::size_t samples() const { return samples_; }
  double last_time() const { return t_last_; }
  const FixCounts& fixes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::size_t samples_ = 0;
  double t_last_;
};

/// The extra odometry.csv columns the pipeline writes, and their values.
std::vector<std::string> odometry_extra_columns(bool fused);
void odometry_extra_values(const PipelineStep& step, const io::RobotConfig& config,
                           std::vector<std::string>& out);

}  // namespace moa::cli
