// moa analyze sensitivity: Kim & Lee Section III for a robot config.
//
// The robot moves with twist v; mouse i sits dp away from its nominal
// position along x or y. The estimate made with the nominal positions is
// then off by e = B A~ v - v (exact, B the nominal LS gain, A~ the true
// Jacobian); to first order e = -(dv_m1 + dv_m2) of eqs. (29)-(30) with the
// measurements held at what the displaced mouse reports (dv_m3 = 0).
#include <fmt/core.h>

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "commands.hpp"
#include "moa/analysis/sensitivity.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/json.hpp"
#include "odometry_options.hpp"

namespace moa::cli {
namespace {

struct AnalyzeArgs {
  std::string config;
  double dp = 0.001;
  std::vector<double> twist{0.3, 0.0, 0.5};
  bool json = false;
};

int run_sensitivity(const AnalyzeArgs& args) {
  const io::RobotConfig config = io::read_config(args.config);
  const SensorArray& array = config.array;
  if (array.size() < 2) throw io::Error(fmt::format("{}: needs at least two sensors", args.config));
  const Eigen::Vector3d v(args.twist[0], args.twist[1], args.twist[2]);

  struct Row {
    std::string sensor;
    char axis;
    Eigen::Vector3d first, exact;
  };
  std::vector<Row> rows;
  for (int i = 0; i < array.size(); ++i) {
    for (int axis = 0; axis < 2; ++axis) {
      PointVectors dp = zeros<Eigen::Vector2d>(), measured = dp, none = dp;
      dp[static_cast<std::size_t>(i)](axis) = args.dp;
      for (int j = 0; j < array.size(); ++j) {
        SensorMount m = array[j];
        m.position += dp[static_cast<std::size_t>(j)];
        measured[static_cast<std::size_t>(j)] = m.point_jacobian() * v;  // what the mouse reports
      }
      const SensitivityTerms t = first_order_sensitivity(array, dp, measured, none);
      // Exact: nominal-geometry estimate minus the true twist. exact_sensitivity
      // gives (estimate with p + dp) - (estimate with p) = v - estimate.
      const Eigen::Vector3d exact = -exact_sensitivity(array, dp, measured, none);
      rows.push_back({config.names[static_cast<std::size_t>(i)], axis == 0 ? 'x' : 'y',
                      -(t.dv1 + t.dv2), exact});
    }
  }
  if (args.json) {
    // Units: dp_m in m; twist (m/s, m/s, rad/s); velocity errors likewise.
    io::JsonWriter json;
    json.begin_object().member("dp_m", args.dp).key("twist").begin_array();
    for (int k = 0; k < 3; ++k) json.value(v(k));
    json.end_array().key("rows").begin_array();
    for (const Row& r : rows) {
      json.begin_object().member("sensor", r.sensor).member("axis", std::string_view(&r.axis, 1));
      json.key("first_order").begin_array();
      for (int k = 0; k < 3; ++k) json.value(r.first(k));
      json.end_array().key("exact").begin_array();
      for (int k = 0; k < 3; ++k) json.value(r.exact(k));
      json.end_array().end_object();
    }
    json.end_array().end_object();
    fmt::print("{}\n", json.str());
    return 0;
  }
  fmt::print(
      "Velocity error of the estimate made with nominal positions when one mouse is\n"
      "{} mm off along one axis; twist vx {} m/s, vy {} m/s, omega {} rad/s.\n"
      "first order: Kim & Lee eqs. (29)-(30); exact: least squares with the true positions.\n\n",
      args.dp * 1e3, v(0), v(1), v(2));
  fmt::print("{:<12} {:>4} | {:>12} {:>12} {:>14} | {:>12} {:>12} {:>14}\n", "sensor", "axis",
             "dvx mm/s", "dvy mm/s", "domega mrad/s", "exact dvx", "exact dvy", "exact domega");
  for (const Row& r : rows) {
    fmt::print("{:<12} {:>4} | {:>12.5f} {:>12.5f} {:>14.5f} | {:>12.5f} {:>12.5f} {:>14.5f}\n",
               r.sensor, r.axis, 1e3 * r.first(0), 1e3 * r.first(1), 1e3 * r.first(2),
               1e3 * r.exact(0), 1e3 * r.exact(1), 1e3 * r.exact(2));
  }
  return 0;
}

}  // namespace

void add_analyze(CLI::App& app, Action& action) {
  auto args = std::make_shared<AnalyzeArgs>();
  auto* cmd = app.add_subcommand("analyze", "Analyses of a sensor array");
  cmd->require_subcommand(1);
  auto* sens = cmd->add_subcommand(
      "sensitivity", "Velocity error per mm of mounting error (Kim & Lee Section III)");
  sens->add_option("--config", args->config, "Robot config v1 (YAML)")
      ->required()
      ->check(CLI::ExistingFile);
  sens->add_option("--dp", args->dp, "Position error applied to each coordinate in turn, m")
      ->check(kPositive)
      ->capture_default_str();
  sens->add_option("--twist", args->twist, "Robot twist VX,VY,OMEGA (m/s, m/s, rad/s)")
      ->expected(3)
      ->delimiter(',')
      ->capture_default_str();
  sens->add_flag("--json", args->json, "One JSON object on stdout, SI units");
  sens->callback([&action, args] { action = [args] { return run_sensitivity(*args); }; });
}

}  // namespace moa::cli
