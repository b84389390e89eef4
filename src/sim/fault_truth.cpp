#include "moa/sim/fault_truth.hpp"

#include "moa/formats/json.hpp"

namespace moa::sim {

FaultTruth::FaultTruth(const Scenario& scenario)
    : scenario_(scenario),
      row_period_(scenario.sensor_model.row_period()),
      imu_period_(
          static_cast<double>(frames_per_row(scenario.sensor_model.frame_rate, scenario.imu.rate)) /
          scenario.sensor_model.frame_rate),
      loss_(scenario.nominal.names.size()) {}

void FaultTruth::extend(std::vector<FaultInterval>& out, Open& open, const std::string& source,
                        const char* kind, bool faulty, double start, double end, double period) {
  // A gap of at most one row joins two faulty rows into one interval.
  if (open.open && start > open.end + 1.5 * period) {
    out.push_back({source, kind, open.start, open.end, true, 0.0});
    open.open = false;
  }
  if (!faulty) return;
  if (!open.open) {
    open = {true, start, end};
  } else {
    open.end = end;
  }
}

void FaultTruth::mice(const MiceRecord& r) {
  const auto i = static_cast<std::size_t>(r.sensor);
  if (r.end <= 0.0) return;  // the zero row at t = 0
  extend(emergent_, loss_[i], scenario_.nominal.names[i], "tracking_loss",
         (r.row.faults & kFaultTrackingLoss) != 0, r.end - row_period_, r.end, row_period_);
}

void FaultTruth::imu(const ImuRecord& r, double row_start) {
  const double end = r.t - scenario_.imu.latency;
  extend(emergent_, saturated_, "gyro", "saturated", r.saturated, row_start, end, imu_period_);
}

std::vector<FaultInterval> FaultTruth::intervals() const {
  const double end =
      static_cast<double>(scenario_.frame_count()) / scenario_.sensor_model.frame_rate;
  std::vector<FaultInterval> out;
  for (std::size_t i = 0; i < scenario_.faults.size(); ++i) {
    for (const FaultWindow& w : scenario_.faults[i].windows) {
      FaultInterval f{scenario_.nominal.names[i],
                      fault_name(w.kind),
                      w.start,
                      std::min(w.end, end),
                      false,
                      0.0};
      if (w.kind == kFaultDirty) f.amount = w.retained;
      if (w.kind == kFaultDrift) f.amount = w.scale;
      if (w.kind == kFaultSpike) f.amount = w.magnitude;
      out.push_back(f);
    }
  }
  for (const GyroFault& g : scenario_.imu.faults) {
    out.push_back({"gyro", g.kind == GyroFault::kStuck ? "stuck" : "bias_step", g.start,
                   std::min(g.end, end), false, g.kind == GyroFault::kBiasStep ? g.step : 0.0});
  }
  for (const SlipBurst& b : scenario_.drive.slip.bursts) {
    out.push_back({b.wheel < 0 ? std::string("wheels") : "wheels[" + std::to_string(b.wheel) + "]",
                   "slip_burst", b.start, std::min(b.end, end), false, b.slip});
  }
  // Intervals still open at the end of the run.
  std::vector<FaultInterval> emergent = emergent_;
  for (std::size_t i = 0; i < loss_.size(); ++i) {
    if (loss_[i].open) {
      emergent.push_back(
          {scenario_.nominal.names[i], "tracking_loss", loss_[i].start, loss_[i].end, true, 0.0});
    }
  }
  if (saturated_.open) {
    emergent.push_back({"gyro", "saturated", saturated_.start, saturated_.end, true, 0.0});
  }
  out.insert(out.end(), emergent.begin(), emergent.end());
  return out;
}

std::string FaultTruth::json(std::uint64_t seed) const {
  io::JsonWriter j;
  j.begin_object()
      .member("scenario", scenario_.name)
      .member("seed", static_cast<std::uint64_t>(seed))
      .member("duration",
              static_cast<double>(scenario_.frame_count()) / scenario_.sensor_model.frame_rate)
      .key("faults")
      .begin_array();
  for (const FaultInterval& f : intervals()) {
    j.begin_object()
        .member("source", f.source)
        .member("kind", f.kind)
        .member("start", f.start)
        .member("end", f.end)
        .member("emergent", f.emergent)
        .member("amount", f.amount)
        .end_object();
  }
  j.end_array().key("unobservable").begin_array();
  for (const std::string& text : scenario_.unobservable) j.value(text);
  j.end_array().end_object();
  return j.str() + "\n";
}

}  // namespace moa::sim
