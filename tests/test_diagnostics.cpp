// diagnostics.csv: the status record of every source, written and read back.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>

#include "moa/formats/diagnostics_csv.hpp"
#include "moa/formats/error.hpp"
#include "support/synth.hpp"

namespace moa::io {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

OdometryStep step_at(const ArraySample& sample) {
  OdometryStep step;
  step.sample = &sample;
  return step;
}

TEST(DiagnosticsCsv, EverySelectedSourceRoundTrips) {
  const fs::path file = test::scratch_dir("diagnostics") / "d.csv";
  ArraySample sample;
  sample.t = 0.25;
  sample.size = 3;
  OdometryStep step = step_at(sample);
  step.estimate.source = Source::kWheels;
  step.estimate.estimate.used = 0b001;
  step.estimate.excluded[1] = Exclusion::kCommonMode;
  step.estimate.excluded[2] = Exclusion::kUnselected;
  step.estimate.tests.sensor[0] = 0.125;
  step.estimate.tests.sensor[1] = 3.5;
  step.estimate.tests.wheels = 0.75;  // prior left NaN: not tested
  {
    DiagnosticsCsvWriter w(file, {"m1", "m2", "m3"}, 0b011);
    w.write(step);
    EXPECT_FALSE(fs::exists(file)) << "nothing appears before commit";
    w.commit();
  }
  const auto rows = read_diagnostics_csv(file);
  ASSERT_EQ(rows.size(), 4u);  // m1, m2 (m3 not selected), wheels, prior
  EXPECT_EQ(rows[0].source, "m1");
  EXPECT_DOUBLE_EQ(rows[0].test_ratio, 0.125);
  EXPECT_TRUE(rows[0].fused);
  EXPECT_EQ(rows[0].reason, "");
  EXPECT_EQ(rows[1].source, "m2");
  EXPECT_DOUBLE_EQ(rows[1].test_ratio, 3.5);
  EXPECT_FALSE(rows[1].fused);
  EXPECT_EQ(rows[1].reason, "common-mode");
  EXPECT_EQ(rows[2].source, "wheels");
  EXPECT_TRUE(rows[2].fused);
  EXPECT_DOUBLE_EQ(rows[2].test_ratio, 0.75);
  EXPECT_EQ(rows[3].source, "prior");
  EXPECT_TRUE(std::isnan(rows[3].test_ratio));
  EXPECT_FALSE(rows[3].fused);
  for (const auto& r : rows) EXPECT_DOUBLE_EQ(r.t, 0.25);
}

TEST(DiagnosticsCsv, BadRowsAreRefusedWithFileAndLine) {
  const fs::path dir = test::scratch_dir("diagnostics-bad");
  const struct {
    const char* text;
    const char* error;
  } cases[] = {
      {"t,source,test_ratio,fused\n", "reason"},
      {"t,source,test_ratio,fused,reason\n0.1,m1,-1,1,\n", "d.csv:2"},
      {"t,source,test_ratio,fused,reason\n0.1,m1,1,2,\n", "must be 0 or 1"},
      {"t,source,test_ratio,fused,reason\n0.1,m1,nan,1,\n", "d.csv:2"},
      {"t,source,test_ratio,fused,reason\n0.2,m1,1,1,\n0.1,m1,1,1,\n", "d.csv:3"},
      {"t,source,test_ratio,fused,reason\n0.1,,1,1,\n", "empty source"},
  };
  for (const auto& c : cases) {
    const fs::path file = dir / "d.csv";
    std::ofstream(file) << c.text;
    try {
      read_diagnostics_csv(file);
      ADD_FAILURE() << "no error for " << c.text;
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr(c.error)) << c.text;
    }
  }
}

}  // namespace
}  // namespace moa::io
