// The firmware's PixArt drivers in simavr: PMW3360 / PMW3389 (power-up,
// SROM download of the synthetic test image, SROM_ID and CRC checks, CPI,
// 12-byte bursts, lift) and PMW3901 / PAA5100 (PixArt's init sequence,
// bursts, the quality rule), each against its chip model; and the faults:
// another product ID, a build without an SROM, an image the chip refuses,
// a chip that stops answering.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "firmware_builds.hpp"
#include "pixart_session.hpp"
#include "pmw33xx_model.hpp"
#include "pmw3901_model.hpp"

namespace moa::firmware_sim {
namespace {

// DATA flags (docs/serial-protocol.md) and STATUS states.
constexpr std::uint8_t kFlagOverflow = 0x01;
constexpr std::uint8_t kFlagNoSurface = 0x02;
constexpr std::uint8_t kFlagRejected = 0x04;
constexpr std::uint8_t kFlagFault = 0x08;
constexpr std::uint8_t kOk = 0, kNoAnswer = 1, kWrongId = 2, kNoSrom = 3, kSromRejected = 4,
                       kStopped = 5;
constexpr int kSqualFloor = 16;  // the firmware's SQUAL floor (config.h)
constexpr std::uint8_t kIdleSqual = 100;
constexpr std::uint8_t kTypeShutter = 0x05;
// PMW33xx start-up: 50 ms after the reset, then per sensor about 10 ms of
// SROM_Enable, 4094 bytes 15 us apart plus their transfer and loop (about
// 21 us each at 16 MHz: 86 ms), 10 ms of CRC test: 4 sensors in under 0.5 s.
constexpr double kPmwBootUs = 500000.0;
// PMW3901: 5 ms, then per sensor about 150 writes 50 us apart and the
// sequence's waits (250 ms for the PMW3901, 20 ms for the PAA5100).
constexpr double kFlowBootUs = 1200000.0;

const FirmwareBuild& build_named(const std::string& name) {
  for (const FirmwareBuild& b : kFirmwareBuilds) {
    if (b.name == name) return b;
  }
  throw std::runtime_error("no firmware build " + name);
}

std::vector<MotionFrame> random_script(std::uint32_t seed, std::size_t frames, int range) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> count(-range, range);
  std::uniform_int_distribution<int> squal(30, 120);
  std::uniform_int_distribution<int> shutter(0x0040, 0x0400);
  std::vector<MotionFrame> script(frames);
  for (MotionFrame& f : script) {
    f.dx = static_cast<std::int16_t>(count(rng));
    f.dy = static_cast<std::int16_t>(count(rng));
    f.squal = static_cast<std::uint8_t>(squal(rng));
    f.shutter = static_cast<std::uint16_t>(shutter(rng));
  }
  return script;
}

/// The quality rule of the flow chips (PixArt's, firmware/src/pmw3901.h):
/// SQUAL below 0x19 with Shutter_Upper at 0x1F.
bool flow_rejects(const MotionFrame& f) { return f.squal < 0x19 && (f.shutter >> 8) == 0x1F; }

struct Expected {
  serial::SensorCounts counts;
  std::uint16_t shutter = 0;
};

/// What the protocol says a record over reads [begin, end) must hold: the
/// counts of the reads the chip reported as on the surface (a lifted chip
/// reports none) and, for a flow chip, not refused by the quality rule.
Expected expected_record(const std::vector<MotionFrame>& script, std::size_t begin, std::size_t end,
                         bool flow) {
  long long sx = 0, sy = 0;
  int min_squal = 255;
  std::uint16_t shutter = 0;
  std::uint8_t flags = 0;
  for (std::size_t r = begin; r < end; ++r) {
    const MotionFrame f = r < script.size() ? script[r] : MotionFrame{0, 0, kIdleSqual};
    min_squal = std::min<int>(min_squal, f.squal);
    shutter = std::max(shutter, f.shutter);
    if (f.squal < kSqualFloor || f.lifted) flags |= kFlagNoSurface;
    if (f.lifted) continue;
    if (flow && flow_rejects(f)) {
      flags |= kFlagRejected;
      continue;
    }
    sx += f.dx;
    sy += f.dy;
  }
  const auto clamp = [&flags](long long v) {
    constexpr long long lo = std::numeric_limits<std::int16_t>::min();
    constexpr long long hi = std::numeric_limits<std::int16_t>::max();
    if (v < lo || v > hi) flags |= kFlagOverflow;
    return static_cast<std::int16_t>(std::clamp(v, lo, hi));
  };
  Expected e;
  e.counts.dx = clamp(sx);
  e.counts.dy = clamp(sy);
  e.counts.squal = static_cast<std::uint8_t>(min_squal);
  e.counts.flags = flags;
  e.shutter = shutter;
  return e;
}

/// Every DATA record of sensor i against the script over exactly its reads,
/// and the SHUTTER frame of the same sequence number.
void expect_sensor_matches_script(PixartSession& s, std::size_t i,
                                  const std::vector<MotionFrame>& script, bool flow) {
  const auto shutters = s.payloads(kTypeShutter);
  std::size_t previous = 0;
  std::size_t d = 0;
  const std::vector<serial::Data> frames = s.data();
  for (const serial::Data& data : frames) {
    SCOPED_TRACE("sequence " + std::to_string(data.sequence) + ", sensor " + std::to_string(i));
    const std::size_t now = s.reads_through(i, data.timestamp);
    const Expected want = expected_record(script, previous, now, flow);
    previous = now;
    EXPECT_EQ(data.sensors[i].dx, want.counts.dx);
    EXPECT_EQ(data.sensors[i].dy, want.counts.dy);
    EXPECT_EQ(data.sensors[i].squal, want.counts.squal);
    EXPECT_EQ(data.sensors[i].flags, want.counts.flags);
    // SHUTTER: type, u16 sequence, N, then N x u16 (docs/serial-protocol.md);
    // the last DATA frame's may still be on its way.
    if (d == shutters.size() && &data == &frames.back()) break;
    ASSERT_LT(d, shutters.size());
    const auto& p = shutters[d++];
    ASSERT_EQ(p.size(), 4u + 2u * static_cast<std::size_t>(s.build().sensors));
    EXPECT_EQ(p[1] | p[2] << 8, data.sequence);
    EXPECT_EQ(p[4 + 2 * i] | p[5 + 2 * i] << 8, want.shutter);
  }
}

void expect_no_violations(PixartSession& s) {
  const std::vector<std::string> v = s.violations();
  EXPECT_TRUE(v.empty()) << v.size() << " violations, first: " << (v.empty() ? "" : v.front());
}

/// The records of a sensor the firmware does not read: no counts, no
/// surface, and the fault bit if it stopped answering.
void expect_unread(PixartSession& s, std::size_t i, std::uint8_t flags) {
  for (const serial::Data& data : s.data()) {
    EXPECT_EQ(data.sensors[i].dx, 0);
    EXPECT_EQ(data.sensors[i].dy, 0);
    EXPECT_EQ(data.sensors[i].squal, 0);
    EXPECT_EQ(data.sensors[i].flags, flags) << "sequence " << data.sequence;
  }
}

std::unique_ptr<SpiChip> pmw(Pmw33xxModel::Kind kind, std::vector<MotionFrame> script,
                             std::uint8_t product_id = 0,
                             std::vector<std::uint8_t> srom = test_srom_image()) {
  return std::make_unique<Pmw33xxModel>(kind, std::move(script), std::move(srom), kTestSromId,
                                        product_id, kIdleSqual);
}

// ------------------------------------------------------------- PMW3360

TEST(FirmwarePmw3360, UploadsTheSromChecksItAndStreamsSixteenBitCounts) {
  const FirmwareBuild& build = build_named("moa_firmware_test_pmw3360");
  std::vector<std::vector<MotionFrame>> scripts;
  std::vector<std::unique_ptr<SpiChip>> chips;
  for (std::uint32_t i = 0; i < 4; ++i) {
    // Up to 3000 counts a read: 16-bit deltas (at 1600 cpi and 1 kHz that
    // is 1.9 m/s, within the rated 250 in/s).
    scripts.push_back(random_script(900 + i, 120, 3000));
    chips.push_back(pmw(Pmw33xxModel::Kind::kPmw3360, scripts.back()));
  }
  // Sensor 1 is lifted in reads 20..29; sensor 2 loses the surface in 40.
  for (std::size_t r = 20; r < 30; ++r) scripts[1][r].lifted = true;
  scripts[2][40].squal = 5;
  chips[1] = pmw(Pmw33xxModel::Kind::kPmw3360, scripts[1]);
  chips[2] = pmw(Pmw33xxModel::Kind::kPmw3360, scripts[2]);
  PixartSession s(build, std::move(chips));
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 6; }, kPmwBootUs + 100000.0));

  for (std::size_t i = 0; i < 4; ++i) {
    const auto* chip = s.bench().model<Pmw33xxModel>(i);
    EXPECT_TRUE(chip->power_up_reset_seen());
    EXPECT_EQ(chip->srom_bytes(), 4094u);
    EXPECT_TRUE(chip->srom_running());
    EXPECT_TRUE(chip->crc_tested());
    EXPECT_EQ(chip->config2(), 0x00);  // wired: rest modes off
    EXPECT_EQ(chip->cpi(), 1600);      // Config1 = 1600 / 100 - 1
    expect_sensor_matches_script(s, i, scripts[i], false);
  }
  const auto data = s.data();
  EXPECT_EQ(data[25 / 12].sensors[1].flags & kFlagNoSurface, kFlagNoSurface);
  EXPECT_EQ(data[40 / 12].sensors[2].squal, 5);
  ASSERT_FALSE(s.hellos().empty());
  EXPECT_EQ(s.hellos()[0].cpi, 1600);
  // STATUS after the HELLO: every sensor OK.
  const auto statuses = s.statuses();
  ASSERT_FALSE(statuses.empty());
  for (const SensorState& st : statuses[0]) EXPECT_EQ(st.state, kOk);
  // All reads of a frame within config.h's budget for the PMW33xx: 89 us
  // of bus and 1000 cycles of code a sensor (151.5 us at 16 MHz), so within
  // the 1 ms frame.
  EXPECT_LT(s.bench().longest_frame_read_us(), 4 * (89.0 + 1000.0 / 16.0));
  RecordProperty("longest_frame_read_us", std::to_string(s.bench().longest_frame_read_us()));
  // The host decoder read the STATUS frames as the splitter did, skipped
  // SHUTTER as a type it does not know, and counted nothing corrupt.
  const auto host = s.host_statuses();
  ASSERT_EQ(host.size(), statuses.size());
  for (std::size_t f = 0; f < host.size(); ++f) {
    ASSERT_EQ(host[f].n, 4);
    for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(host[f].sensors[i].state, statuses[f][i].state);
  }
  EXPECT_EQ(s.stats().corrupt, 0u);
  EXPECT_EQ(s.stats().unknown, s.payloads(kTypeShutter).size());
  expect_no_violations(s);
}

TEST(FirmwarePmw3360, SetCpiWritesConfig1AndRefusesOtherSteps) {
  const FirmwareBuild& build = build_named("moa_firmware_test_pmw3360");
  std::vector<std::unique_ptr<SpiChip>> chips;
  std::vector<std::vector<MotionFrame>> scripts;
  for (std::uint32_t i = 0; i < 4; ++i) {
    scripts.push_back(random_script(950 + i, 400, 500));
    chips.push_back(pmw(Pmw33xxModel::Kind::kPmw3360, scripts.back()));
  }
  PixartSession s(build, std::move(chips));
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 2; }, kPmwBootUs + 100000.0));
  s.send(serial::SetCpi{5000});
  ASSERT_TRUE(s.run_until([&] { return s.hellos().size() >= 2; }, 30000.0));
  EXPECT_EQ(s.hellos()[1].cpi, 5000);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(s.bench().model<Pmw33xxModel>(i)->cpi(), 5000);
  // 150 is not a multiple of 100, 12100 is past the top: both refused.
  s.send(serial::SetCpi{150});
  ASSERT_TRUE(s.run_until([&] { return s.hellos().size() >= 3; }, 30000.0));
  s.send(serial::SetCpi{12100});
  ASSERT_TRUE(s.run_until([&] { return s.hellos().size() >= 4; }, 30000.0));
  EXPECT_EQ(s.hellos()[2].cpi, 5000);
  EXPECT_EQ(s.hellos()[3].cpi, 5000);
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 8; }, 100000.0));
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(s.bench().model<Pmw33xxModel>(i)->cpi(), 5000);
    expect_sensor_matches_script(s, i, scripts[i], false);
  }
  expect_no_violations(s);  // the burst re-armed after the CPI registers
}

TEST(FirmwarePmw3360, AnotherPartOrNoneIsReportedAndLeftAlone) {
  const FirmwareBuild& build = build_named("moa_firmware_test_pmw3360");
  std::vector<std::unique_ptr<SpiChip>> chips;
  const auto script = random_script(970, 200, 800);
  chips.push_back(pmw(Pmw33xxModel::Kind::kPmw3360, script));
  chips.push_back(pmw(Pmw33xxModel::Kind::kPmw3360, script, Pmw33xxModel::kPmw3389Id));
  chips.push_back(nullptr);  // nothing on chip select 2: MISO reads 0xFF
  chips.push_back(pmw(Pmw33xxModel::Kind::kPmw3360, script));
  PixartSession s(build, std::move(chips));
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 4; }, kPmwBootUs + 100000.0));
  const auto statuses = s.statuses();
  ASSERT_FALSE(statuses.empty());
  EXPECT_EQ(statuses[0][0].state, kOk);
  EXPECT_EQ(statuses[0][1].state, kWrongId);
  EXPECT_EQ(statuses[0][1].detail, Pmw33xxModel::kPmw3389Id);
  EXPECT_EQ(statuses[0][2].state, kNoAnswer);
  EXPECT_EQ(statuses[0][3].state, kOk);
  // The PMW3389 got its reset and the reads of power-up, no SROM, no burst.
  const auto* other = s.bench().model<Pmw33xxModel>(1);
  EXPECT_EQ(other->srom_bytes(), 0u);
  EXPECT_EQ(other->bursts(), 0u);
  expect_unread(s, 1, kFlagNoSurface);
  expect_unread(s, 2, kFlagNoSurface);
  expect_sensor_matches_script(s, 0, script, false);
  expect_sensor_matches_script(s, 3, script, false);
  expect_no_violations(s);
}

TEST(FirmwarePmw3360, AnImageTheChipRefusesIsReported) {
  const FirmwareBuild& build = build_named("moa_firmware_test_pmw3360");
  std::vector<std::uint8_t> other_image = test_srom_image();
  other_image[1000] ^= 0x01;  // the chip expects one bit more or less
  std::vector<std::unique_ptr<SpiChip>> chips;
  const auto script = random_script(980, 200, 800);
  for (int i = 0; i < 4; ++i) chips.push_back(pmw(Pmw33xxModel::Kind::kPmw3360, script));
  chips[2] = pmw(Pmw33xxModel::Kind::kPmw3360, script, 0, other_image);
  PixartSession s(build, std::move(chips));
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 3; }, kPmwBootUs + 100000.0));
  const auto statuses = s.statuses();
  ASSERT_FALSE(statuses.empty());
  EXPECT_EQ(statuses[0][2].state, kSromRejected);
  EXPECT_EQ(statuses[0][2].detail, 0x00);  // SROM_ID stays 0 without a running image
  EXPECT_EQ(s.bench().model<Pmw33xxModel>(2)->srom_bytes(), 4094u);
  EXPECT_EQ(s.bench().model<Pmw33xxModel>(2)->bursts(), 0u);
  expect_unread(s, 2, kFlagNoSurface);
  for (std::size_t i : {0u, 1u, 3u}) EXPECT_EQ(statuses[0][i].state, kOk);
  expect_no_violations(s);
}

TEST(FirmwarePmw3360, ABuildWithoutSromSaysSoAndReadsNothing) {
  const FirmwareBuild& build = build_named("moa_firmware_test_pmw3360_nosrom");
  std::vector<std::unique_ptr<SpiChip>> chips;
  for (int i = 0; i < 4; ++i) {
    chips.push_back(pmw(Pmw33xxModel::Kind::kPmw3360, random_script(990, 100, 100)));
  }
  PixartSession s(build, std::move(chips));
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 3; }, 200000.0));
  const auto statuses = s.statuses();
  ASSERT_FALSE(statuses.empty());
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(statuses[0][i].state, kNoSrom);
    EXPECT_EQ(s.bench().model<Pmw33xxModel>(i)->srom_bytes(), 0u);
    EXPECT_EQ(s.bench().model<Pmw33xxModel>(i)->bursts(), 0u);
    expect_unread(s, i, kFlagNoSurface);
  }
  expect_no_violations(s);
}

TEST(FirmwarePmw3360, AChipThatStopsAnsweringIsReportedAndTheOthersGoOn) {
  const FirmwareBuild& build = build_named("moa_firmware_test_pmw3360");
  std::vector<std::vector<MotionFrame>> scripts;
  std::vector<std::unique_ptr<SpiChip>> chips;
  for (std::uint32_t i = 0; i < 4; ++i) {
    scripts.push_back(random_script(1000 + i, 400, 800));
    chips.push_back(pmw(Pmw33xxModel::Kind::kPmw3360, scripts.back()));
  }
  PixartSession s(build, std::move(chips));
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 3; }, kPmwBootUs + 100000.0));
  auto* dying = s.bench().model<Pmw33xxModel>(1);
  s.run_for(5300.0);  // inside a window
  const double stop_us = s.bench().now_us();
  dying->stop_answering_from(stop_us);
  const std::size_t accesses_before = dying->accesses();
  const std::size_t data_before = s.data().size();
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= data_before + 8; }, 200000.0));

  // Reported: a STATUS frame naming sensor 1 stopped, the others OK.
  const auto statuses = s.statuses();
  ASSERT_GE(statuses.size(), 2u);
  EXPECT_EQ(statuses.back()[1].state, kStopped);
  for (std::size_t i : {0u, 2u, 3u}) EXPECT_EQ(statuses.back()[i].state, kOk);
  // Three silent bursts (MOA_FW_SILENT_READS, config.h; 13 bytes each:
  // the address and 12 data), then the chip is left alone.
  EXPECT_EQ(dying->accesses() - accesses_before, 3u * 13u);
  const auto data = s.data();
  // Every window on time and whole; sensor 1's after the stop: the fault.
  for (std::size_t d = 1; d < data.size(); ++d) {
    EXPECT_EQ(data[d].sequence, d);
    EXPECT_EQ(data[d].timestamp - data[d - 1].timestamp, 12u * 2000u);
  }
  EXPECT_EQ(data.back().sensors[1].flags, kFlagNoSurface | kFlagFault);
  EXPECT_EQ(data.back().sensors[1].dx, 0);
  for (std::size_t i : {0u, 2u, 3u}) expect_sensor_matches_script(s, i, scripts[i], false);
  expect_no_violations(s);
}

// ------------------------------------------------------------- PMW3389

TEST(FirmwarePmw3389, SetsItsSixteenBitResolutionAndStreams) {
  const FirmwareBuild& build = build_named("moa_firmware_test_pmw3389");
  std::vector<std::vector<MotionFrame>> scripts;
  std::vector<std::unique_ptr<SpiChip>> chips;
  for (std::uint32_t i = 0; i < 4; ++i) {
    scripts.push_back(random_script(1100 + i, 200, 6000));
    chips.push_back(pmw(Pmw33xxModel::Kind::kPmw3389, scripts.back()));
  }
  PixartSession s(build, std::move(chips));
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 4; }, kPmwBootUs + 100000.0));
  EXPECT_EQ(s.hellos()[0].cpi, 5000);
  for (std::size_t i = 0; i < 4; ++i) {
    // Resolution_H:L = 5000 / 50 = 100.
    EXPECT_EQ(s.bench().model<Pmw33xxModel>(i)->cpi(), 5000);
    EXPECT_TRUE(s.bench().model<Pmw33xxModel>(i)->srom_running());
    expect_sensor_matches_script(s, i, scripts[i], false);
  }
  s.send(serial::SetCpi{16000});
  ASSERT_TRUE(s.run_until([&] { return s.hellos().size() >= 2; }, 30000.0));
  EXPECT_EQ(s.hellos()[1].cpi, 16000);
  EXPECT_EQ(s.bench().model<Pmw33xxModel>(0)->cpi(), 16000);
  s.send(serial::SetCpi{16050});
  ASSERT_TRUE(s.run_until([&] { return s.hellos().size() >= 3; }, 30000.0));
  EXPECT_EQ(s.hellos()[2].cpi, 16000);
  expect_no_violations(s);
}

// ------------------------------------------------- PMW3901 and PAA5100

/// PixArt's performance-optimisation sequences (PMW3901MB data sheet;
/// PAA5100JE-Q as published in Pimoroni's driver), written out here from
/// those tables on their own, not from the firmware's: "RRVV" writes VV to
/// RR, "Wn" waits n ms. `trims` is the block the sequence writes when 0x73
/// of bank 0x0E reads 0, with c1, c2 the corrected 0x70, 0x71.
const char* const kSequenceA = "7F00 5501 5007 7F0E 4310";
const char* const kSequenceB = "7F00 517B 5000 5500 7F0E";
const char* const kPmw3901C =
    "7F00 61AD 7F03 4000 7F05 41B3 43F1 4514 5B32 5F34 7B08 7F06 441B 40BF 4E3F 7F08 6520 "
    "6A18 7F09 4FAF 5F40 4880 4980 5777 6078 6178 6208 6350 7F0A 4560 7F00 4D11 5580 7421 "
    "751F 4A78 4B78 4408 4550 64FF 651F 7F14 6567 6608 6370 7F15 4848 7F07 410D 4314 4B0E "
    "450F 4442 4C80 7F10 5B02 7F07 4041 7000 W10 3244 7F07 4040 7F06 62F0 6300 7F0D 48C0 "
    "6FD5 7F00 5BA0 4EA8 5A50 4080 W240 7F14 6F1C 7F00";
const char* const kPaa5100C =
    "7F00 61AD 7F03 4000 7F05 41B3 43F1 4514 5F34 7B08 5E34 5B11 6D11 4517 70E5 71E5 7F06 "
    "441B 40BF 4E3F 7F08 6644 6520 6A3A 6105 6205 7F09 4FAF 5F40 4880 4980 5777 6078 6178 "
    "6208 6350 7F0A 4560 7F00 4D11 5580 7421 751F 4A78 4B78 4408 4550 64FF 651F 7F14 6567 "
    "6608 6370 6F1C 7F15 4848 7F07 410D 4314 4B0E 450F 4442 4C80 7F10 5B02 7F07 4041 W10 "
    "7F00 3200 7F07 4040 7F06 68F0 6900 7F0D 48C0 6FD5 7F00 5BA0 4EA8 5A90 4080 731F W10 "
    "7300";

struct Step {
  int reg;    ///< -1: a wait
  int value;  ///< the value, or the wait in ms
};

void append(std::vector<Step>& out, const std::string& text) {
  std::size_t at = 0;
  while (at < text.size()) {
    const std::size_t end = std::min(text.find(' ', at), text.size());
    const std::string word = text.substr(at, end - at);
    if (word[0] == 'W') {
      out.push_back({-1, std::stoi(word.substr(1))});
    } else {
      out.push_back(
          {std::stoi(word.substr(0, 2), nullptr, 16), std::stoi(word.substr(2), nullptr, 16)});
    }
    at = end + 1;
  }
}

/// The whole sequence for a chip with `trim`: 0x48 is 0x04 if 0x67 bit 7
/// is set, else 0x02; the trim block (c1 = 0x70 + 14 if at most 28, then
/// + 11 if above 28, at most 0x3F; c2 = 0x71 x 45 / 100) if 0x73 is 0.
std::vector<Step> expected_sequence(bool paa5100, const Pmw3901Model::Trim& trim) {
  std::vector<Step> out;
  append(out, kSequenceA);
  out.push_back({0x48, (trim.r67 & 0x80) ? 0x04 : 0x02});
  append(out, kSequenceB);
  if (trim.r73 == 0x00) {
    int c1 = trim.r70;
    if (c1 <= 28) c1 += 14;
    if (c1 > 28) c1 += 11;
    c1 = std::clamp(c1, 0, 0x3F);
    append(out, "7F00 61AD 5170 7F0E");
    out.push_back({0x70, c1});
    out.push_back({0x71, trim.r71 * 45 / 100});
  }
  append(out, paa5100 ? kPaa5100C : kPmw3901C);
  return out;
}

void expect_sequence(const Pmw3901Model& chip, const std::vector<Step>& want) {
  const auto& writes = chip.writes();
  std::size_t w = 0;
  double wait_ms = 0.0;
  for (const Step& step : want) {
    if (step.reg < 0) {
      wait_ms = step.value;
      continue;
    }
    ASSERT_LT(w, writes.size()) << "the sequence stopped after " << w << " writes";
    EXPECT_EQ(writes[w].reg, step.reg) << "write " << w;
    EXPECT_EQ(writes[w].value, step.value) << "write " << w;
    if (wait_ms > 0.0) {
      ASSERT_GT(w, 0u);
      EXPECT_GE(writes[w].t_us - writes[w - 1].t_us, wait_ms * 1000.0) << "wait before write " << w;
      wait_ms = 0.0;
    }
    ++w;
  }
  EXPECT_EQ(writes.size(), w) << "writes after the sequence";
}

/// Flow frames at 10 ms each: up to 60 counts; reads 10..14 dark and at
/// full shutter (refused), 20..24 dark but exposed (kept), 30 no surface.
std::vector<MotionFrame> flow_script(std::uint32_t seed) {
  auto script = random_script(seed, 80, 60);
  for (std::size_t r = 10; r < 15; ++r) {
    script[r].squal = 0x12;
    script[r].shutter = 0x1F40;
  }
  for (std::size_t r = 20; r < 25; ++r) {
    script[r].squal = 0x12;
    script[r].shutter = 0x0800;
  }
  script[30].squal = 5;
  return script;
}

class FirmwareFlow : public ::testing::TestWithParam<std::string> {};

TEST_P(FirmwareFlow, InitSequenceIsPixArtsAndBurstsFollowTheQualityRule) {
  const FirmwareBuild& build = build_named(GetParam());
  const bool paa5100 = build.sensor == "PAA5100";
  const Pmw3901Model::Trim trims[4] = {
      {0x80, 20, 100, 0x00}, {0x00, 40, 7, 0x00}, {0x80, 10, 30, 0x01}, {0x7F, 60, 255, 0x00}};
  std::vector<std::vector<MotionFrame>> scripts;
  std::vector<std::unique_ptr<SpiChip>> chips;
  for (std::uint32_t i = 0; i < 4; ++i) {
    scripts.push_back(flow_script(1200 + i));
    chips.push_back(std::make_unique<Pmw3901Model>(scripts.back(), trims[i]));
  }
  PixartSession s(build, std::move(chips));
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 40; }, kFlowBootUs + 500000.0));
  for (std::size_t i = 0; i < 4; ++i) {
    SCOPED_TRACE("sensor " + std::to_string(i));
    expect_sequence(*s.bench().model<Pmw3901Model>(i), expected_sequence(paa5100, trims[i]));
    expect_sensor_matches_script(s, i, scripts[i], true);
  }
  // Reads within config.h's budget: 104 us of bus and 900 cycles a sensor.
  EXPECT_LT(s.bench().longest_frame_read_us(), 4 * (104.0 + 900.0 / 16.0));
  RecordProperty("longest_frame_read_us", std::to_string(s.bench().longest_frame_read_us()));
  const auto data = s.data();
  EXPECT_EQ(data[12].sensors[0].flags, kFlagRejected);
  EXPECT_EQ(data[22].sensors[0].flags, 0);
  EXPECT_EQ(data[30].sensors[0].flags, kFlagNoSurface);
  // No resolution to set: HELLO says 0 (not given), SET_CPI is refused.
  EXPECT_EQ(s.hellos()[0].cpi, 0);
  s.send(serial::SetCpi{1600});
  ASSERT_TRUE(s.run_until([&] { return s.hellos().size() >= 2; }, 50000.0));
  EXPECT_EQ(s.hellos()[1].cpi, 0);
  const auto statuses = s.statuses();
  ASSERT_FALSE(statuses.empty());
  for (const SensorState& st : statuses[0]) EXPECT_EQ(st.state, kOk);
  EXPECT_EQ(s.stats().corrupt, 0u);
  expect_no_violations(s);
}

TEST_P(FirmwareFlow, AnotherPartNoneOrAChipThatStopsIsReported) {
  const FirmwareBuild& build = build_named(GetParam());
  std::vector<std::unique_ptr<SpiChip>> chips;
  const auto script = flow_script(1300);
  chips.push_back(std::make_unique<Pmw3901Model>(script));
  chips.push_back(std::make_unique<Pmw3901Model>(script, Pmw3901Model::Trim{}, 0x42));
  chips.push_back(nullptr);
  chips.push_back(std::make_unique<Pmw3901Model>(script));
  PixartSession s(build, std::move(chips));
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 3; }, kFlowBootUs));
  auto* dying = s.bench().model<Pmw3901Model>(3);
  dying->stop_answering_from(s.bench().now_us());
  const std::size_t accesses_before = dying->accesses();
  ASSERT_TRUE(s.run_until([&] { return s.data().size() >= 12; }, 200000.0));

  const auto statuses = s.statuses();
  ASSERT_GE(statuses.size(), 2u);
  EXPECT_EQ(statuses[0][0].state, kOk);
  EXPECT_EQ(statuses[0][1].state, kWrongId);
  EXPECT_EQ(statuses[0][1].detail, 0x42);
  EXPECT_EQ(statuses[0][2].state, kNoAnswer);
  EXPECT_EQ(statuses[0][3].state, kOk);
  EXPECT_EQ(statuses.back()[3].state, kStopped);
  // The other part had the power-up reset and no init write; the dead chip
  // three silent bursts and no more.
  EXPECT_TRUE(s.bench().model<Pmw3901Model>(1)->writes().empty());
  EXPECT_EQ(dying->accesses() - accesses_before, 3u * 13u);
  expect_unread(s, 1, kFlagNoSurface);
  expect_unread(s, 2, kFlagNoSurface);
  EXPECT_EQ(s.data().back().sensors[3].flags, kFlagNoSurface | kFlagFault);
  expect_sensor_matches_script(s, 0, script, true);
  const auto data = s.data();
  for (std::size_t d = 0; d < data.size(); ++d) EXPECT_EQ(data[d].sequence, d);
  expect_no_violations(s);
}

INSTANTIATE_TEST_SUITE_P(Builds, FirmwareFlow,
                         ::testing::Values("moa_firmware_pmw3901_atmega328p",
                                           "moa_firmware_paa5100_atmega328p",
                                           "moa_firmware_paa5100_atmega8"));

}  // namespace
}  // namespace moa::firmware_sim
