// `moa experiment sekimori-table4` and `sekimori-fig6` on a few runs: the
// paper's orderings, and the camera's error against its configured noise.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <regex>
#include <string>

#include "support/run.hpp"

namespace moa {
namespace {

using ::testing::HasSubstr;

/// "method" (after "speed" or "fault" when present) -> {field -> value} from
/// the JSON rows.
std::map<std::string, std::map<std::string, double>> rows_of(const std::string& json) {
  std::map<std::string, std::map<std::string, double>> out;
  const std::regex row(R"(\{([^{}]*)\})");
  const std::regex number(R"re("(\w+)": (-?[0-9.eE+-]+))re");
  const std::regex text(R"re("(speed|fault|method)": "([^"]*)")re");
  for (auto r = std::sregex_iterator(json.begin(), json.end(), row); r != std::sregex_iterator();
       ++r) {
    const std::string body = (*r)[1];
    std::string key;
    for (auto t = std::sregex_iterator(body.begin(), body.end(), text); t != std::sregex_iterator();
         ++t) {
      key += (key.empty() ? "" : " ") + (*t)[2].str();
    }
    for (auto n = std::sregex_iterator(body.begin(), body.end(), number);
         n != std::sregex_iterator(); ++n) {
      out[key][(*n)[1]] = std::stod((*n)[2]);
    }
  }
  return out;
}

TEST(ExperimentSekimori, Table4OrderingOfThePaperOnThreeRuns) {
  const auto r = test::run_moa("experiment sekimori-table4 --runs 3 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto rows = rows_of(r.out);
  ASSERT_EQ(rows.size(), 10u) << r.out;
  const auto mm = [&](const std::string& key) {
    EXPECT_TRUE(rows.count(key)) << key;
    return 1e3 * rows[key]["max_translation_m"];
  };
  const auto deg = [&](const std::string& key) { return rows[key]["max_heading_rad"]; };
  for (const std::string s : {"a ", "b "}) {
    // Mice far better than wheels, at both speeds (the paper: 4-5 times; our
    // voting at (b) about 2 times, as it lets more lost counts through).
    EXPECT_LT(2.0 * mm(s + "4 mice, voting (Sekimori)"), mm(s + "wheels")) << s;
    EXPECT_LT(3.0 * mm(s + "4 mice, consensus"), mm(s + "wheels")) << s;
    EXPECT_LT(3.0 * deg(s + "4 mice, consensus"), deg(s + "wheels")) << s;
    // The oracle is a lower bound up to the noise of three runs; consensus
    // sits near it and is never worse than the voting by more than that noise.
    EXPECT_LT(mm(s + "4 mice, consensus"), 1.25 * mm(s + "4 mice, oracle selection") + 1.0) << s;
    EXPECT_LT(mm(s + "4 mice, consensus"), 1.05 * mm(s + "4 mice, voting (Sekimori)") + 0.5) << s;
  }
  // At (b), over the sensors' rated speed: two mice far worse than four, and
  // worse than the wheels (paper: 627 mm against 239 mm).
  EXPECT_GT(mm("b 2 mice"), 3.0 * mm("b 4 mice, voting (Sekimori)"));
  EXPECT_GT(mm("b 2 mice"), mm("b wheels"));
  // The paper's own figures travel with ours.
  EXPECT_NEAR(1e3 * rows["b 2 mice"]["paper_max_translation_m"], 627.237, 1e-3);
}

TEST(ExperimentSekimori, Table4TextShowsOursBesideThePapers) {
  const auto r = test::run_moa("experiment sekimori-table4 --runs 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("paper mm"));
  EXPECT_THAT(r.out, HasSubstr("61.6"));  // voting at (b), Table 4
}

TEST(ExperimentSekimori, Fig6CameraFusionBeatsEachSourceAlone) {
  const auto r = test::run_moa("experiment sekimori-fig6 --runs 3 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto rows = rows_of(r.out);
  ASSERT_EQ(rows.size(), 5u) << r.out;
  auto& camera = rows["camera alone"];
  auto& wheels = rows["wheel dead reckoning"];
  auto& wheels_camera = rows["wheels + camera (EKF)"];
  auto& mice = rows["mouse dead reckoning (consensus)"];
  auto& mice_camera = rows["mice + camera (EKF)"];
  // The camera's fixes have 5 mm noise per axis (scenario sekimori-b): the
  // RMS of the 2-D error is sqrt(2) * 5 mm; ~100 fixes per run, 3 runs, so
  // the relative standard error of the RMS is ~ 1/sqrt(4 * 300) < 3 %.
  EXPECT_NEAR(camera["rms_translation_m"], std::sqrt(2.0) * 0.005, 0.15 * std::sqrt(2.0) * 0.005);
  // Fusion bounds the drift of either dead reckoning...
  EXPECT_LT(wheels_camera["max_translation_m"], 0.5 * wheels["max_translation_m"]);
  EXPECT_LT(mice_camera["max_translation_m"], mice["max_translation_m"]);
  // ...and with mice it is better than the camera's own fixes.
  EXPECT_LT(mice_camera["rms_translation_m"], camera["rms_translation_m"]);
  // Heading: position fixes alone leave the wheels' heading poor; with the
  // mice it comes out well (the paper's point, Section 4.3).
  EXPECT_LT(3.0 * mice_camera["max_heading_rad"], wheels_camera["max_heading_rad"]);
}

TEST(ExperimentRobustFaults, ConsensusIsNeverWorseThanTheVotingOnAnySimulatedFault) {
  const auto r = test::run_moa("experiment robust-faults --runs 3 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto rows = rows_of(r.out);
  ASSERT_EQ(rows.size(), 20u) << r.out;
  for (const std::string fault :
       {"tracking loss", "liftoff, no flag", "dirty floor", "spikes", "stuck"}) {
    const double ls = rows[fault + " least squares, all"]["max_translation_m"];
    const double voting = rows[fault + " voting (Sekimori)"]["max_translation_m"];
    const double consensus = rows[fault + " consensus"]["max_translation_m"];
    const double oracle = rows[fault + " oracle selection"]["max_translation_m"];
    ASSERT_GT(oracle, 0.0) << fault;
    // The fault matters: least squares over all four sensors suffers from it.
    EXPECT_GT(ls, 1.5 * oracle) << fault;
    // Never worse than the voting beyond the noise of three runs (5 % + 0.5 mm).
    EXPECT_LT(consensus, 1.05 * voting + 5e-4) << fault;
    // At the oracle, except for a stuck sensor: frozen counts of a cruise
    // agree with the others until the motion changes, which no selection
    // from counts can see (docs/experiments.md).
    if (fault != "stuck") {
      EXPECT_LT(consensus, 1.25 * oracle + 1e-3) << fault;
    }
  }
}

}  // namespace
}  // namespace moa
