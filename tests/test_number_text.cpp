// The number writers of the CSV files (io/csv.hpp): byte for byte what fmt's
// "{}" and "{:.6g}" write, which is what the files held before they existed,
// and the shortest text reads back as the same double.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "moa/formats/csv.hpp"
#include "support/synth.hpp"

namespace moa::io {
namespace {

std::string shortest(double v) {
  char text[kMaxNumberText];
  return {text, write_shortest(text, v)};
}

std::string six_g(double v) {
  char text[kMaxNumberText];
  return {text, write_6g(text, v)};
}

std::string shortest_time(double v) {
  char text[kMaxNumberText];
  return {text, write_shortest_time(text, v)};
}

void expect_as_fmt(double v) {
  ASSERT_EQ(shortest(v), fmt::format("{}", v)) << std::bit_cast<std::uint64_t>(v);
  ASSERT_EQ(shortest_time(v), fmt::format("{}", v)) << std::bit_cast<std::uint64_t>(v);
  ASSERT_EQ(six_g(v), fmt::format("{:.6g}", v)) << std::bit_cast<std::uint64_t>(v);
  double back = 0.0;
  const std::string text = shortest(v);
  std::from_chars(text.data(), text.data() + text.size(), back);
  ASSERT_EQ(std::bit_cast<std::uint64_t>(back), std::bit_cast<std::uint64_t>(v)) << text;
}

TEST(NumberText, EdgeCasesAreWrittenAsFmtWritesThem) {
  const double max = std::numeric_limits<double>::max();
  const double tiny = std::numeric_limits<double>::denorm_min();
  const std::vector<double> values{0.0,
                                   -0.0,
                                   1.0,
                                   -1.0,
                                   0.1,
                                   0.001,
                                   1e-4,
                                   1e-5,
                                   0.00012345,
                                   9.99999e-5,
                                   1e15,
                                   1e16,
                                   1e17,
                                   123456789012345678.0,
                                   9999999999999998.0,
                                   1e22,
                                   1e100,
                                   1e-100,
                                   1e300,
                                   1e-300,
                                   1e-310,
                                   max,
                                   -max,
                                   tiny,
                                   std::numeric_limits<double>::min(),
                                   0.5,
                                   2.5,
                                   100.0,
                                   123456.0,
                                   999999.0,
                                   999999.5,
                                   9999995.0,
                                   1234565.0,
                                   1234575.0,
                                   0.1234565,
                                   1000000.0,
                                   99999.95,
                                   0.3,
                                   2.0 / 3.0,
                                   1.0 / 3.0,
                                   6e-5,
                                   0.00060000000000000001,
                                   3.14159265358979};
  for (const double v : values) {
    expect_as_fmt(v);
    expect_as_fmt(-v);
  }
}

TEST(NumberText, RandomBitPatternsAreWrittenAsFmtWritesThem) {
  std::mt19937_64 rng(19);
  for (int i = 0; i < 300000; ++i) {
    const double v = std::bit_cast<double>(rng());
    if (std::isfinite(v)) expect_as_fmt(v);
  }
}

TEST(NumberText, OdometryLikeValuesAreWrittenAsFmtWritesThem) {
  // Poses, twists, standard deviations and covariances span these decades;
  // integers and short decimals (times, rates) hit the carry and tie paths.
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int decade = -12; decade <= 8; ++decade) {
    for (int i = 0; i < 20000; ++i) expect_as_fmt(unit(rng) * std::pow(10.0, decade));
  }
  for (std::int64_t k = 0; k < 200000; ++k) {
    expect_as_fmt(static_cast<double>(k) / 1000.0);
    expect_as_fmt(static_cast<double>(k * 37 + 1000000));
  }
}

TEST(NumberText, ShortDecimalsAreWrittenAsFmtWritesThem) {
  // The writer's short path (m * 10^-6 below 10^9) and its edges: decimals
  // with up to eight places, epoch times as the synchroniser computes them,
  // values near 10^9 and near the doubles' spacing of 10^-6.
  std::mt19937_64 rng(23);
  const double scale[] = {1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8};
  for (int i = 0; i < 200000; ++i) {
    const auto m = static_cast<double>(rng() % 2000000000000u);
    expect_as_fmt(m / scale[rng() % 9]);
  }
  for (std::int64_t k = 0; k < 100000; ++k) {
    expect_as_fmt(0.37 + static_cast<double>(k + 1) * (1.0 / 1000.0));
    expect_as_fmt(1234.5 + static_cast<double>(k) * 0.001);
  }
  for (double v : {999999999.999999, 999999999.9999999, 1e9, 1e9 - 0.5, 4503599627.370496, 0.000001,
                   0.0000015, 0.0000005, 1e-7, 0.5, 0.25, 0.125, 0.0625, 0.03125}) {
    for (int i = 0; i < 50; ++i) {
      expect_as_fmt(v);
      v = std::nextafter(v, 2e9);
    }
  }
}

TEST(NumberText, NonFiniteValuesAreWrittenAsFmtWritesThem) {
  for (const double v :
       {std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
        std::numeric_limits<double>::quiet_NaN()}) {
    EXPECT_EQ(shortest(v), fmt::format("{}", v));
    EXPECT_EQ(six_g(v), fmt::format("{:.6g}", v));
  }
}

// The reader's short paths (plain decimals, integers) must give what
// std::from_chars gives, and leave everything else to it.
TEST(NumberText, ReaderNumbersAreFromCharsValues) {
  std::vector<std::string> texts{"0",   "-0",  "1.",  ".5",   "-.5",    "007.25",
                                 "0.1", "0.3", "1e3", "1E-3", "2.5e+2", "-1.5e-7"};
  std::mt19937_64 rng(5);
  for (int i = 0; i < 20000; ++i) {
    const auto m = rng() >> (rng() % 64);
    const int k = static_cast<int>(rng() % 25);
    std::string digits = std::to_string(m);
    if (k > 0) {
      digits.insert(
          0,
          std::string(
              static_cast<std::size_t>(std::max(0, k + 1 - static_cast<int>(digits.size()))), '0'));
      digits.insert(digits.size() - static_cast<std::size_t>(k), ".");
    }
    texts.push_back((i % 3 == 0 ? "-" : "") + digits);
  }
  for (const auto m : {(std::uint64_t{1} << 53) - 1, std::uint64_t{1} << 53,
                       (std::uint64_t{1} << 53) + 1, std::uint64_t{9999999999999999999u}}) {
    texts.push_back(std::to_string(m));
    texts.push_back("0." + std::to_string(m));
  }
  const auto dir = test::scratch_dir("number_text");
  {
    std::ofstream out(dir / "n.csv");
    out << "x\n";
    for (const auto& text : texts) out << text << "\n";
  }
  CsvReader csv(dir / "n.csv");
  for (const auto& text : texts) {
    ASSERT_TRUE(csv.next());
    double expected = 0.0;
    std::from_chars(text.data(), text.data() + text.size(), expected);
    ASSERT_EQ(std::bit_cast<std::uint64_t>(csv.number(0)), std::bit_cast<std::uint64_t>(expected))
        << text;
  }
}

TEST(NumberText, ReaderIntegersAreFromCharsValues) {
  std::vector<std::string> texts{"0",
                                 "-0",
                                 "7",
                                 "-12",
                                 "123456789012345678",
                                 "-123456789012345678",
                                 "1234567890123456789",
                                 "9223372036854775807"};
  const auto dir = test::scratch_dir("number_text_int");
  {
    std::ofstream out(dir / "n.csv");
    out << "x\n";
    for (const auto& text : texts) out << text << "\n";
  }
  CsvReader csv(dir / "n.csv");
  for (const auto& text : texts) {
    ASSERT_TRUE(csv.next());
    std::int64_t expected = 0;
    std::from_chars(text.data(), text.data() + text.size(), expected);
    EXPECT_EQ(csv.integer(0, INT64_MIN, INT64_MAX), expected) << text;
  }
}

}  // namespace
}  // namespace moa::io
