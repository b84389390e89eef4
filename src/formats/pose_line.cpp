#include "moa/formats/pose_line.hpp"

#include <array>

#include "moa/formats/json.hpp"

namespace moa::io {
namespace {

// The 3x3 over (a, b, yaw) as the 6x6 row-major over the three axes and
// three rotations: planar indices 0, 1 and 5, the others 0.
void planar_6x6(JsonWriter& json, const Mat3& c) {
  constexpr std::array<int, 6> kPlanar{0, 1, -1, -1, -1, 2};
  json.begin_array();
  for (int r = 0; r < 6; ++r) {
    for (int k = 0; k < 6; ++k) {
      const int i = kPlanar[static_cast<std::size_t>(r)];
      const int j = kPlanar[static_cast<std::size_t>(k)];
      json.value(i < 0 || j < 0 ? 0.0 : static_cast<double>(c(i, j)));
    }
  }
  json.end_array();
}

}  // namespace

PoseLineWriter::PoseLineWriter(const std::vector<std::string>& names) : names_(names) {
  for (const auto& name : names) quoted_.push_back(json_string(name));
}

std::string_view PoseLineWriter::format(const OdometryStep& step, std::uint64_t seq) {
  const RobustEstimate& e = step.estimate;
  const Twist2& v = e.estimate.twist;
  JsonWriter json;
  json.begin_object()
      .member("seq", seq)
      .member("t", step.t())
      .member("frame_id", "odom")
      .member("child_frame_id", "base_link")
      .member("x", static_cast<double>(step.pose.t.x()))
      .member("y", static_cast<double>(step.pose.t.y()))
      .member("theta", static_cast<double>(step.pose.theta))
      .member("vx", static_cast<double>(v.v.x()))
      .member("vy", static_cast<double>(v.v.y()))
      .member("omega", static_cast<double>(v.omega))
      .key("pose_covariance");
  if (step.fused) {
    planar_6x6(json, step.pose_covariance);
  } else {
    json.null();
  }
  json.key("twist_covariance");
  planar_6x6(json, e.estimate.covariance);
  json.member("source", to_name(e.source)).key("used").begin_array();
  for (std::size_t i = 0; i < names_.size(); ++i) {
    if (contains(e.estimate.used, static_cast<int>(i))) json.raw(quoted_[i]);
  }
  json.end_array().key("excluded").begin_object();
  for (std::size_t i = 0; i < names_.size(); ++i) {
    if (contains(e.estimate.used, static_cast<int>(i))) continue;
    json.key(names_[i]).value(to_name(e.excluded[i]));
  }
  json.end_object().end_object();
  line_ = json.str();
  line_ += '\n';
  return line_;
}

}  // namespace moa::io
