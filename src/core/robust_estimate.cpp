#include "moa/core/robust_estimate.hpp"

namespace moa {

const char* describe(Source source) {
  switch (source) {
    case Source::kMice:
      return "mice";
    case Source::kWheels:
      return "wheels";
    case Source::kHold:
      return "hold";
  }
  return "?";
}

const char* describe(Exclusion exclusion) {
  switch (exclusion) {
    case Exclusion::kNone:
      return "used";
    case Exclusion::kLift:
      return "lift";
    case Exclusion::kInconsistent:
      return "inconsistent";
    case Exclusion::kUnreliable:
      return "unreliable";
    case Exclusion::kFallback:
      return "fallback";
    case Exclusion::kUnselected:
      return "unselected";
    case Exclusion::kFaulty:
      return "faulty";
    case Exclusion::kFrozen:
      return "frozen";
    case Exclusion::kZero:
      return "zero";
    case Exclusion::kDrift:
      return "drift";
    case Exclusion::kProbation:
      return "probation";
    case Exclusion::kCalibration:
      return "calibration";
    case Exclusion::kCommonMode:
      return "common-mode";
  }
  return "?";
}

}  // namespace moa
