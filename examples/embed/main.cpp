// Embedding moa's core: three mice under a robot, counts in, pose out.
//
// The robot spins in place at 1/3 rad/s (Kim & Lee's Section V motion) with
// its mice on a regular triangle of radius 0.3 m; after 3 s its heading is 1 rad.
#include <cmath>
#include <cstdio>
#include <numbers>
#include <variant>

#include "moa/core/dead_reckoner.hpp"
#include "moa/core/estimate.hpp"

int main() {
  moa::SensorMount adns;  // ADNS-3080 at 1600 cpi
  adns.cpi = moa::kAdns3080.cpi;
  const moa::SensorArray mice = moa::regular_polygon(3, 0.3, -std::numbers::pi / 6.0, adns);

  const double dt = 0.01;  // s, one sample
  auto built = moa::LsEstimator::create(mice, moa::all_sensors(mice.size()), dt);
  if (auto* error = std::get_if<moa::GeometryError>(&built)) {
    std::fprintf(stderr, "geometry refused: %s\n", moa::describe(*error));
    return 1;
  }
  const auto& estimator = std::get<moa::LsEstimator>(built);

  const moa::Twist2 spin{{0.0, 0.0}, 1.0 / 3.0};
  moa::DeadReckoner reckoner;
  moa::ArraySample sample;
  sample.size = mice.size();
  sample.dt = dt;
  for (int k = 0; k < 300; ++k) {
    for (int i = 0; i < mice.size(); ++i)
      sample.counts[static_cast<std::size_t>(i)] = mice[i].counts(spin, dt);
    reckoner.step(estimator.estimate(sample)->twist, dt);
  }
  const moa::Pose2& pose = reckoner.pose();
  std::printf("after 3 s: x = %.6f m, y = %.6f m, theta = %.6f rad\n", pose.t.x(), pose.t.y(),
              pose.theta);
  return std::abs(pose.theta - 1.0) < 1e-9 && pose.t.norm() < 1e-9 ? 0 : 1;
}
