// moa serial protocol v1 (docs/serial-protocol.md): CRC, COBS, payload
// layout, the decoder's behaviour on good, corrupt, truncated and random
// streams, and the host's sequence and timestamp bookkeeping.
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>
#include <variant>
#include <vector>

#include "moa/formats/error.hpp"
#include "moa/sources/serial_protocol.hpp"

namespace moa::io::serial {
namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes bytes_of(const std::string& text) { return Bytes(text.begin(), text.end()); }

// A wire frame around any payload, valid CRC: the way to reach the payload
// checks with frames encode() would not make.
Bytes frame_of(const Bytes& payload) {
  Bytes block = payload;
  const std::uint16_t crc = crc16(payload);
  block.push_back(static_cast<std::uint8_t>(crc & 0xFF));
  block.push_back(static_cast<std::uint8_t>(crc >> 8));
  Bytes wire = cobs_encode(block);
  wire.push_back(0);
  return wire;
}

struct Fed {
  std::vector<Message> messages;
  std::vector<FrameError> errors;
};

Fed feed(Decoder& decoder, const Bytes& bytes) {
  Fed fed;
  for (const std::uint8_t byte : bytes) {
    if (auto out = decoder.push(byte)) {
      if (auto* message = std::get_if<Message>(&*out)) {
        fed.messages.push_back(*message);
      } else {
        fed.errors.push_back(std::get<FrameError>(*out));
      }
    }
  }
  return fed;
}

Data sample_data(std::uint16_t sequence, std::uint32_t timestamp, std::uint8_t n) {
  Data data;
  data.sequence = sequence;
  data.timestamp = timestamp;
  data.n = n;
  for (std::uint8_t i = 0; i < n; ++i) {
    data.sensors[i] = {static_cast<std::int16_t>(-300 + 97 * i), static_cast<std::int16_t>(i * 7),
                       static_cast<std::uint8_t>(40 + i), static_cast<std::uint8_t>(i % 4)};
  }
  return data;
}

// ---------------------------------------------------------------------- CRC

TEST(Crc16, MatchesTheCatalogueCheckValue) { EXPECT_EQ(crc16(bytes_of("123456789")), 0x29B1); }

TEST(Crc16, EmptyInputGivesTheInitialValue) { EXPECT_EQ(crc16({}), 0xFFFF); }

TEST(Crc16, MessageFollowedByItsCrcBigEndianLeavesZeroRemainder) {
  // For a non-reflected CRC without final XOR, appending the CRC (most
  // significant byte first) makes the register end at zero: a property of
  // polynomial division, independent of how crc16 is written.
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> byte(0, 255), length(0, 300);
  for (int trial = 0; trial < 200; ++trial) {
    Bytes message(static_cast<std::size_t>(length(rng)));
    for (auto& b : message) b = static_cast<std::uint8_t>(byte(rng));
    const std::uint16_t crc = crc16(message);
    message.push_back(static_cast<std::uint8_t>(crc >> 8));
    message.push_back(static_cast<std::uint8_t>(crc & 0xFF));
    EXPECT_EQ(crc16(message), 0) << trial;
  }
}

TEST(Crc16, DetectsEverySingleBitError) {
  const Bytes message = bytes_of("moa serial protocol");
  const std::uint16_t good = crc16(message);
  for (std::size_t i = 0; i < message.size(); ++i) {
    for (int bit = 0; bit < 8; ++bit) {
      Bytes flipped = message;
      flipped[i] = static_cast<std::uint8_t>(flipped[i] ^ (1 << bit));
      EXPECT_NE(crc16(flipped), good);
    }
  }
}

// --------------------------------------------------------------------- COBS

Bytes run_from(int first, int count) {
  Bytes out;
  for (int i = 0; i < count; ++i) out.push_back(static_cast<std::uint8_t>(first + i));
  return out;
}

Bytes concat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const auto& part : parts) out.insert(out.end(), part.begin(), part.end());
  return out;
}

TEST(Cobs, EncodesThePublishedExamples) {
  // The examples of Cheshire & Baker's COBS as commonly tabulated.
  EXPECT_EQ(cobs_encode(Bytes{}), (Bytes{0x01}));
  EXPECT_EQ(cobs_encode(Bytes{0x00}), (Bytes{0x01, 0x01}));
  EXPECT_EQ(cobs_encode(Bytes{0x00, 0x00}), (Bytes{0x01, 0x01, 0x01}));
  EXPECT_EQ(cobs_encode(Bytes{0x00, 0x11, 0x00}), (Bytes{0x01, 0x02, 0x11, 0x01}));
  EXPECT_EQ(cobs_encode(Bytes{0x11, 0x22, 0x00, 0x33}), (Bytes{0x03, 0x11, 0x22, 0x02, 0x33}));
  EXPECT_EQ(cobs_encode(Bytes{0x11, 0x22, 0x33, 0x44}), (Bytes{0x05, 0x11, 0x22, 0x33, 0x44}));
  EXPECT_EQ(cobs_encode(Bytes{0x11, 0x00, 0x00, 0x00}), (Bytes{0x02, 0x11, 0x01, 0x01, 0x01}));
  // 01..FE: one full run, no trailing code.
  EXPECT_EQ(cobs_encode(run_from(1, 254)), concat({Bytes{0xFF}, run_from(1, 254)}));
  // 00 01..FD.
  EXPECT_EQ(cobs_encode(concat({Bytes{0x00}, run_from(1, 253)})),
            concat({Bytes{0x01, 0xFE}, run_from(1, 253)}));
  // 01..FF: a full run, then a run of one.
  EXPECT_EQ(cobs_encode(run_from(1, 255)),
            concat({Bytes{0xFF}, run_from(1, 254), Bytes{0x02, 0xFF}}));
  // 02..FF 00.
  EXPECT_EQ(cobs_encode(concat({run_from(2, 254), Bytes{0x00}})),
            concat({Bytes{0xFF}, run_from(2, 254), Bytes{0x01, 0x01}}));
  // 03..FF 00 01.
  EXPECT_EQ(cobs_encode(concat({run_from(3, 253), Bytes{0x00, 0x01}})),
            concat({Bytes{0xFE}, run_from(3, 253), Bytes{0x02, 0x01}}));
}

TEST(Cobs, RoundTripsRandomPayloadsWithoutZerosInTheBlock) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> length(0, 600), byte(0, 255), kind(0, 3);
  for (int trial = 0; trial < 2000; ++trial) {
    Bytes payload(static_cast<std::size_t>(length(rng)));
    // Mix of plain random bytes, zero-heavy payloads and long non-zero runs.
    const int k = kind(rng);
    for (auto& b : payload) {
      const int value = byte(rng);
      b = static_cast<std::uint8_t>(k == 0   ? value
                                    : k == 1 ? (value < 128 ? 0 : value)
                                             : value | 1);
    }
    const Bytes block = cobs_encode(payload);
    for (const std::uint8_t b : block) ASSERT_NE(b, 0) << trial;
    // Overhead: one code byte per started run of 254.
    EXPECT_LE(block.size(), payload.size() + payload.size() / 254 + 1);
    const auto decoded = cobs_decode(block);
    ASSERT_TRUE(decoded.has_value()) << trial;
    EXPECT_EQ(*decoded, payload) << trial;
  }
}

TEST(Cobs, RoundTripsRunsAroundTheBlockLimit) {
  for (const int length : {253, 254, 255, 256, 508, 509, 510}) {
    for (const bool zero_after : {false, true}) {
      Bytes payload(static_cast<std::size_t>(length), 0x5A);
      if (zero_after) payload.push_back(0);
      const auto decoded = cobs_decode(cobs_encode(payload));
      ASSERT_TRUE(decoded.has_value()) << length;
      EXPECT_EQ(*decoded, payload) << length << " " << zero_after;
    }
  }
}

TEST(Cobs, DecodesTheLongerEncodingWithATrailingEmptyRun) {
  // Some encoders close a full run with a code 0x01; it means nothing more.
  const Bytes block = concat({Bytes{0xFF}, run_from(1, 254), Bytes{0x01}});
  EXPECT_EQ(cobs_decode(block), run_from(1, 254));
}

TEST(Cobs, RejectsACodeThatRunsPastTheBlock) {
  EXPECT_FALSE(cobs_decode(Bytes{0x05, 0x11, 0x22}).has_value());
  EXPECT_FALSE(cobs_decode(Bytes{0x02, 0x11, 0x09}).has_value());
}

TEST(Cobs, RejectsAZeroInsideTheBlock) {
  EXPECT_FALSE(cobs_decode(Bytes{0x03, 0x11, 0x00}).has_value());
  EXPECT_FALSE(cobs_decode(Bytes{0x00}).has_value());
}

// ------------------------------------------------------------ payload layout

TEST(Encode, DataPayloadHasTheDocumentedLayout) {
  Data data;
  data.sequence = 0x0102;
  data.timestamp = 0x03040506;
  data.n = 2;
  data.sensors[0] = {-2, 0x0100, 0, 3};
  data.sensors[1] = {-32768, 32767, 255, 1};
  const Bytes wire = encode(data);
  ASSERT_EQ(wire.back(), 0);
  const auto frame = cobs_decode(Bytes(wire.begin(), wire.end() - 1));
  ASSERT_TRUE(frame.has_value());
  const Bytes payload{0x02, 0x02, 0x01, 0x06, 0x05, 0x04, 0x03, 0x02,  // type seq ts n
                      0xFE, 0xFF, 0x00, 0x01, 0x00, 0x03,              // sensor 0
                      0x00, 0x80, 0xFF, 0x7F, 0xFF, 0x01};             // sensor 1
  ASSERT_EQ(frame->size(), payload.size() + 2);
  EXPECT_EQ(Bytes(frame->begin(), frame->end() - 2), payload);
  const std::uint16_t crc = crc16(payload);
  EXPECT_EQ((*frame)[payload.size()], crc & 0xFF);
  EXPECT_EQ((*frame)[payload.size() + 1], crc >> 8);
  // Wire size: 8 + 6N payload, 2 CRC, 1 COBS code byte (under 254), 1 delimiter.
  EXPECT_EQ(encode(sample_data(0, 0, 4)).size(), 8u + 6u * 4u + 2u + 1u + 1u);
}

TEST(Encode, HelloPayloadHasTheDocumentedLayout) {
  Hello hello;
  hello.k = 12;
  hello.frame_rate = 6400;
  hello.cpi = 1600;
  hello.tick_hz = 1000000;
  hello.names = {"m1", "left"};
  const Bytes wire = encode(hello);
  const auto frame = cobs_decode(Bytes(wire.begin(), wire.end() - 1));
  ASSERT_TRUE(frame.has_value());
  const Bytes payload{0x01, 0x01, 0x02, 0x0C, 0x00, 0x00, 0x19, 0x40, 0x06, 0x40, 0x42,
                      0x0F, 0x00, 0x02, 'm',  '1',  0x04, 'l',  'e',  'f',  't'};
  EXPECT_EQ(Bytes(frame->begin(), frame->end() - 2), payload);
}

TEST(Encode, HostCommandsHaveTheDocumentedLayout) {
  const auto payload = [](const Message& m) {
    const Bytes wire = encode(m);
    const auto frame = cobs_decode(Bytes(wire.begin(), wire.end() - 1));
    return Bytes(frame->begin(), frame->end() - 2);
  };
  EXPECT_EQ(payload(SetK{500}), (Bytes{0x10, 0xF4, 0x01}));
  EXPECT_EQ(payload(SetCpi{400}), (Bytes{0x11, 0x90, 0x01}));
  EXPECT_EQ(payload(HelloRequest{}), (Bytes{0x12}));
}

TEST(Encode, RefusesWhatTheFormatCannotHold) {
  Data data;
  data.n = 17;
  EXPECT_THROW(encode(data), Error);
  Hello hello;
  hello.names = {std::string(256, 'a')};
  EXPECT_THROW(encode(hello), Error);
  hello.names.assign(20, std::string(15, 'a'));  // 13 + 20 * 16 bytes > 255
  EXPECT_THROW(encode(hello), Error);
}

// ------------------------------------------------------------------ decoder

TEST(Decoder, DecodesEveryMessageTypeItEncodes) {
  Hello hello;
  hello.k = 7;
  hello.frame_rate = 2000;
  hello.cpi = 400;
  hello.tick_hz = 32768;
  for (int i = 0; i < 16; ++i) hello.names.push_back("s" + std::to_string(i));
  const std::vector<Message> sent{hello,
                                  sample_data(65535, 0xFFFFFFF0u, 16),
                                  sample_data(3, 9, 1),
                                  SetK{1000},
                                  SetCpi{1600},
                                  HelloRequest{}};
  Decoder decoder;
  Bytes stream;
  for (const auto& m : sent) {
    const Bytes wire = encode(m);
    stream.insert(stream.end(), wire.begin(), wire.end());
  }
  const Fed fed = feed(decoder, stream);
  EXPECT_TRUE(fed.errors.empty());
  ASSERT_EQ(fed.messages.size(), sent.size());
  const auto& h = std::get<Hello>(fed.messages[0]);
  EXPECT_EQ(h.k, 7);
  EXPECT_EQ(h.frame_rate, 2000);
  EXPECT_EQ(h.cpi, 400);
  EXPECT_EQ(h.tick_hz, 32768u);
  EXPECT_EQ(h.names, hello.names);
  for (const std::size_t i : {1u, 2u}) {
    const auto& want = std::get<Data>(sent[i]);
    const auto& got = std::get<Data>(fed.messages[i]);
    EXPECT_EQ(got.sequence, want.sequence);
    EXPECT_EQ(got.timestamp, want.timestamp);
    ASSERT_EQ(got.n, want.n);
    for (std::size_t s = 0; s < want.n; ++s) {
      EXPECT_EQ(got.sensors[s].dx, want.sensors[s].dx);
      EXPECT_EQ(got.sensors[s].dy, want.sensors[s].dy);
      EXPECT_EQ(got.sensors[s].squal, want.sensors[s].squal);
      EXPECT_EQ(got.sensors[s].flags, want.sensors[s].flags);
    }
  }
  EXPECT_EQ(std::get<SetK>(fed.messages[3]).k, 1000);
  EXPECT_EQ(std::get<SetCpi>(fed.messages[4]).cpi, 1600);
  EXPECT_TRUE(std::holds_alternative<HelloRequest>(fed.messages[5]));
  EXPECT_EQ(decoder.stats().frames, sent.size());
  EXPECT_EQ(decoder.stats().corrupt, 0u);
}

TEST(Decoder, GyroFrameRoundTripsItsFieldsAndRate) {
  Gyro gyro;
  gyro.sequence = 0xBEEF;
  gyro.sum = -123456789;  // below -2^16: all four bytes and the sign in use
  gyro.n = 1000;
  gyro.lsb_per_dps_x10 = 655;
  gyro.flags = kGyroSaturated;
  const Bytes wire = encode(gyro);
  // 12 payload bytes + 2 CRC, one COBS code byte per zero-free run, delimiter.
  Bytes payload{0x03, 0xEF, 0xBE};
  const auto raw = static_cast<std::uint32_t>(gyro.sum);
  for (int shift = 0; shift < 32; shift += 8) payload.push_back((raw >> shift) & 0xFF);
  payload.insert(payload.end(), {0xE8, 0x03, 0x8F, 0x02, 0x01});
  EXPECT_EQ(wire, frame_of(payload));
  Decoder decoder;
  const Fed fed = feed(decoder, wire);
  ASSERT_EQ(fed.messages.size(), 1u);
  const auto& got = std::get<Gyro>(fed.messages[0]);
  EXPECT_EQ(got.sequence, gyro.sequence);
  EXPECT_EQ(got.sum, gyro.sum);
  EXPECT_EQ(got.n, gyro.n);
  EXPECT_EQ(got.lsb_per_dps_x10, gyro.lsb_per_dps_x10);
  EXPECT_EQ(got.flags, gyro.flags);
  // -123456789 LSB / 1000 samples / 65.5 LSB per deg/s, in rad/s.
  EXPECT_NEAR(got.rate(), -123456.789 / 65.5 * 3.14159265358979 / 180.0, 1e-9);
}

// STATUS (0x04): type, N, then N x (state, detail), as documented.
TEST(Decoder, StatusFrameHasTheDocumentedLayoutAndRoundTrips) {
  Status st;
  st.n = 3;
  st.sensors[0] = {0, 0};
  st.sensors[1] = {2, 0x17};
  st.sensors[2] = {5, 0};
  const Bytes payload{0x04, 3, 0, 0, 2, 0x17, 5, 0};
  Bytes want = payload;
  const std::uint16_t crc = crc16(payload);
  want.push_back(static_cast<std::uint8_t>(crc & 0xFF));
  want.push_back(static_cast<std::uint8_t>(crc >> 8));
  Bytes wire = cobs_encode(want);
  wire.push_back(0);
  EXPECT_EQ(encode(st), wire);
  Decoder decoder;
  const Fed fed =
      feed(decoder,
           concat({wire, frame_of({0x04, 2, 0, 0, 1}), frame_of({0x04, 0}), frame_of({0x04, 17})}));
  ASSERT_EQ(fed.messages.size(), 1u);
  const auto& got = std::get<Status>(fed.messages[0]);
  ASSERT_EQ(got.n, 3);
  EXPECT_EQ(got.sensors[1].state, 2);
  EXPECT_EQ(got.sensors[1].detail, 0x17);
  EXPECT_EQ(got.sensors[2].state, 5);
  // A record cut short, and N of 0 or past 16: dropped with their reason.
  ASSERT_EQ(fed.errors.size(), 3u);
  EXPECT_EQ(fed.errors[0], FrameError::kBadLength);
  EXPECT_EQ(fed.errors[1], FrameError::kBadField);
  EXPECT_EQ(fed.errors[2], FrameError::kBadField);
  EXPECT_EQ(describe_sensor_state(got.sensors[1]), "another part (product ID 0x17), left alone");
  EXPECT_EQ(describe_sensor_state(SensorStatus{4, 0}),
            "SROM refused (SROM_ID 0x00): the wrong image for this chip, or the CRC test failed");
}

TEST(Decoder, OldReaderSkipsAFrameOfANewTypeBetweenDataFrames) {
  // What a reader that does not know a type sees: a good frame it skips,
  // the DATA frames around it whole, nothing counted corrupt.
  Decoder decoder;
  const Fed fed = feed(decoder, concat({encode(sample_data(1, 10, 2)),
                                        frame_of({0x7E, 1, 0, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11}),
                                        encode(sample_data(2, 20, 2))}));
  ASSERT_EQ(fed.messages.size(), 2u);
  EXPECT_EQ(std::get<Data>(fed.messages[0]).sequence, 1);
  EXPECT_EQ(std::get<Data>(fed.messages[1]).sequence, 2);
  ASSERT_EQ(fed.errors.size(), 1u);
  EXPECT_EQ(fed.errors[0], FrameError::kUnknownType);
  EXPECT_EQ(decoder.stats().unknown, 1u);
  EXPECT_EQ(decoder.stats().corrupt, 0u);
}

TEST(Decoder, TruncatedOrCorruptGyroFramesAreCountedAndTheNextDecodes) {
  Gyro gyro;
  gyro.sequence = 3;
  gyro.sum = 65500;
  gyro.n = 12;
  gyro.lsb_per_dps_x10 = 655;
  const Bytes wire = encode(gyro);
  // Every cut: the frame's head, then a delimiter.
  for (std::size_t cut = 1; cut + 1 < wire.size(); ++cut) {
    Decoder decoder;
    Bytes stream(wire.begin(), wire.begin() + static_cast<long>(cut));
    stream.push_back(0);
    const Fed fed = feed(decoder, concat({stream, encode(sample_data(4, 40, 1))}));
    EXPECT_EQ(decoder.stats().corrupt, 1u) << cut;
    ASSERT_EQ(fed.messages.size(), 1u) << cut;
    EXPECT_EQ(std::get<Data>(fed.messages[0]).sequence, 4) << cut;
  }
  // Every single-bit error of every byte before the delimiter.
  for (std::size_t at = 0; at + 1 < wire.size(); ++at) {
    for (int bit = 0; bit < 8; ++bit) {
      Bytes bad = wire;
      bad[at] = static_cast<std::uint8_t>(bad[at] ^ (1u << bit));
      Decoder decoder;
      const Fed fed = feed(decoder, concat({bad, Bytes{0}, encode(sample_data(4, 40, 1))}));
      // A flipped byte may become a delimiter and split the block in two.
      EXPECT_GE(decoder.stats().corrupt, 1u) << at << " " << bit;
      ASSERT_FALSE(fed.messages.empty()) << at << " " << bit;
      EXPECT_TRUE(std::holds_alternative<Data>(fed.messages.back())) << at << " " << bit;
      for (const auto& m : fed.messages) EXPECT_FALSE(std::holds_alternative<Gyro>(m));
    }
  }
}

TEST(Decoder, IgnoresEmptyBlocks) {
  Decoder decoder;
  Bytes stream{0, 0, 0};
  const Bytes wire = encode(HelloRequest{});
  stream.insert(stream.end(), wire.begin(), wire.end());
  stream.push_back(0);
  const Fed fed = feed(decoder, stream);
  EXPECT_EQ(fed.messages.size(), 1u);
  EXPECT_EQ(decoder.stats().corrupt, 0u);
}

TEST(Decoder, EachMalformedFrameIsDroppedWithItsReason) {
  struct Case {
    const char* what;
    Bytes wire;
    FrameError error;
  };
  Bytes bad_crc = frame_of({0x12});
  bad_crc[1] ^= 0x01;  // inside the payload; the COBS structure stays valid
  Bytes data_one = frame_of({0x02, 0, 0, 0, 0, 0, 0, 1, 1, 0, 2, 0, 9, 0});
  const auto hello = [](std::uint8_t version, std::uint8_t n, std::uint16_t k, std::uint32_t hz,
                        const Bytes& names) {
    Bytes p{0x01,
            version,
            n,
            static_cast<std::uint8_t>(k & 0xFF),
            static_cast<std::uint8_t>(k >> 8),
            0,
            0,
            0,
            0,
            static_cast<std::uint8_t>(hz & 0xFF),
            static_cast<std::uint8_t>((hz >> 8) & 0xFF),
            static_cast<std::uint8_t>((hz >> 16) & 0xFF),
            static_cast<std::uint8_t>(hz >> 24)};
    p.insert(p.end(), names.begin(), names.end());
    return frame_of(p);
  };
  const std::vector<Case> cases{
      {"code past the delimiter", {0x05, 0x12, 0x34, 0x00}, FrameError::kCobs},
      {"type only, no CRC", {0x02, 0x12, 0x00}, FrameError::kTooShort},
      {"two bytes", {0x03, 0x12, 0x34, 0x00}, FrameError::kTooShort},
      {"bad CRC", bad_crc, FrameError::kCrc},
      {"unknown type", frame_of({0x55}), FrameError::kUnknownType},
      {"type zero", frame_of({0x00, 0x01}), FrameError::kUnknownType},
      {"hello request with a byte more", frame_of({0x12, 0x00}), FrameError::kBadLength},
      {"set K short", frame_of({0x10, 0x05}), FrameError::kBadLength},
      {"set K zero", frame_of({0x10, 0x00, 0x00}), FrameError::kBadField},
      {"set K 1001", frame_of({0x10, 0xE9, 0x03}), FrameError::kBadField},
      {"set cpi zero", frame_of({0x11, 0x00, 0x00}), FrameError::kBadField},
      {"data header short", frame_of({0x02, 0, 0, 0, 0, 0, 0}), FrameError::kBadLength},
      {"data without sensors", frame_of({0x02, 0, 0, 0, 0, 0, 0, 0}), FrameError::kBadField},
      {"data with 17 sensors", frame_of({0x02, 0, 0, 0, 0, 0, 0, 17}), FrameError::kBadField},
      {"data one record short", frame_of({0x02, 0, 0, 0, 0, 0, 0, 2, 1, 0, 2, 0, 9, 0}),
       FrameError::kBadLength},
      {"data a byte long", frame_of({0x02, 0, 0, 0, 0, 0, 0, 1, 1, 0, 2, 0, 9, 0, 0}),
       FrameError::kBadLength},
      {"hello short", frame_of({0x01, 0x01, 0x01}), FrameError::kBadLength},
      {"hello version 2", hello(2, 1, 1, 1000, {1, 'a'}), FrameError::kBadField},
      {"hello no sensors", hello(1, 0, 1, 1000, {}), FrameError::kBadField},
      {"hello K zero", hello(1, 1, 0, 1000, {1, 'a'}), FrameError::kBadField},
      {"hello tick rate zero", hello(1, 1, 1, 0, {1, 'a'}), FrameError::kBadField},
      {"hello empty name", hello(1, 1, 1, 1000, {0}), FrameError::kBadField},
      {"hello name of 16", hello(1, 1, 1, 1000, concat({Bytes{16}, Bytes(16, 'a')})),
       FrameError::kBadField},
      {"hello name with comma", hello(1, 1, 1, 1000, {3, 'a', ',', 'b'}), FrameError::kBadField},
      {"hello name with space", hello(1, 1, 1, 1000, {3, 'a', ' ', 'b'}), FrameError::kBadField},
      {"hello name cut", hello(1, 1, 1, 1000, {3, 'a'}), FrameError::kBadLength},
      {"hello missing name", hello(1, 2, 1, 1000, {1, 'a'}), FrameError::kBadLength},
      {"hello trailing byte", hello(1, 1, 1, 1000, {1, 'a', 'b'}), FrameError::kBadLength},
      {"gyro a byte short", frame_of({0x03, 1, 0, 5, 0, 0, 0, 1, 0, 0x8F, 0x02}),
       FrameError::kBadLength},
      {"gyro a byte long", frame_of({0x03, 1, 0, 5, 0, 0, 0, 1, 0, 0x8F, 0x02, 0, 0}),
       FrameError::kBadLength},
      {"gyro without samples", frame_of({0x03, 1, 0, 5, 0, 0, 0, 0, 0, 0x8F, 0x02, 0}),
       FrameError::kBadField},
      {"gyro sensitivity zero", frame_of({0x03, 1, 0, 5, 0, 0, 0, 1, 0, 0, 0, 0}),
       FrameError::kBadField},
  };
  for (const auto& c : cases) {
    Decoder decoder;
    const Fed fed = feed(decoder, c.wire);
    ASSERT_EQ(fed.errors.size(), 1u) << c.what;
    EXPECT_EQ(fed.errors[0], c.error) << c.what << ": " << describe(fed.errors[0]);
    EXPECT_TRUE(fed.messages.empty()) << c.what;
    // A well-framed unknown type is a newer device's frame: skipped, not corrupt.
    const bool unknown = c.error == FrameError::kUnknownType;
    EXPECT_EQ(decoder.stats().corrupt, unknown ? 0u : 1u) << c.what;
    EXPECT_EQ(decoder.stats().unknown, unknown ? 1u : 0u) << c.what;
    EXPECT_EQ(decoder.stats().frames, 0u) << c.what;
    // The decoder is in step again for the next frame.
    EXPECT_EQ(feed(decoder, data_one).messages.size(), 1u) << c.what;
  }
}

TEST(Decoder, OverlongBlockIsCountedAndMemoryStaysBounded) {
  Decoder decoder;
  const Fed fed = feed(decoder, concat({Bytes(100000, 0x42), Bytes{0}, encode(HelloRequest{})}));
  ASSERT_EQ(fed.errors.size(), 1u);
  EXPECT_EQ(fed.errors[0], FrameError::kBadLength);
  EXPECT_EQ(decoder.stats().overlong, 1u);
  EXPECT_EQ(decoder.stats().corrupt, 1u);
  EXPECT_EQ(fed.messages.size(), 1u);
}

TEST(Decoder, LargestValidFrameIsNotOverlong) {
  Hello hello;  // 13 + 15 * 16 = 253 payload bytes, no zero in the names
  for (int i = 0; i < 15; ++i) hello.names.push_back(std::string(15, static_cast<char>('a' + i)));
  Decoder decoder;
  const Fed fed = feed(decoder, encode(hello));
  ASSERT_EQ(fed.messages.size(), 1u);
  EXPECT_EQ(std::get<Hello>(fed.messages[0]).names, hello.names);
}

TEST(Decoder, JoinsAStreamMidFrameAndResynchronises) {
  Bytes stream;
  for (std::uint16_t s = 0; s < 20; ++s) {
    const Bytes wire = encode(sample_data(s, 1000u * s, 4));
    stream.insert(stream.end(), wire.begin(), wire.end());
  }
  const std::size_t frame_size = encode(sample_data(0, 0, 4)).size();
  for (std::size_t skip = 1; skip + 1 < frame_size; ++skip) {
    Decoder decoder;
    const Fed fed = feed(decoder, Bytes(stream.begin() + static_cast<long>(skip), stream.end()));
    EXPECT_EQ(fed.messages.size(), 19u) << skip;
    EXPECT_EQ(decoder.stats().corrupt, 1u) << skip;
    EXPECT_EQ(std::get<Data>(fed.messages.front()).sequence, 1) << skip;
  }
}

TEST(Decoder, CorruptedBytesLoseOnlyTheirFrames) {
  std::mt19937 rng(3);
  const int n_frames = 400;
  std::vector<Bytes> frames;
  for (int s = 0; s < n_frames; ++s) {
    frames.push_back(encode(sample_data(static_cast<std::uint16_t>(s), 977u * s, 3)));
  }
  std::bernoulli_distribution corrupt(0.2);
  std::uniform_int_distribution<int> nonzero(1, 255);
  Bytes stream;
  std::vector<int> expected;
  for (int s = 0; s < n_frames; ++s) {
    Bytes wire = frames[static_cast<std::size_t>(s)];
    if (corrupt(rng)) {
      // Replace one non-delimiter byte by a different non-zero byte: the
      // frame stays delimited, and the CRC catches any single-byte change.
      std::uniform_int_distribution<std::size_t> at(0, wire.size() - 2);
      const std::size_t i = at(rng);
      std::uint8_t value;
      do value = static_cast<std::uint8_t>(nonzero(rng));
      while (value == wire[i]);
      wire[i] = value;
    } else {
      expected.push_back(s);
    }
    stream.insert(stream.end(), wire.begin(), wire.end());
  }
  Decoder decoder;
  const Fed fed = feed(decoder, stream);
  ASSERT_EQ(fed.messages.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(std::get<Data>(fed.messages[i]).sequence, expected[i]);
  }
  EXPECT_EQ(decoder.stats().corrupt, static_cast<std::uint64_t>(n_frames) - expected.size());
}

TEST(Decoder, TruncatedFrameCostsItselfAndTheNextOnly) {
  // Without its delimiter, a cut frame merges with the next one into one
  // corrupt block; the frame after that decodes.
  const Bytes a = encode(sample_data(1, 10, 2));
  const Bytes b = encode(sample_data(2, 20, 2));
  const Bytes c = encode(sample_data(3, 30, 2));
  for (std::size_t cut = 1; cut + 1 < a.size(); ++cut) {
    Decoder decoder;
    const Fed fed =
        feed(decoder, concat({Bytes(a.begin(), a.begin() + static_cast<long>(cut)), b, c}));
    ASSERT_EQ(fed.messages.size(), 1u) << cut;
    EXPECT_EQ(std::get<Data>(fed.messages[0]).sequence, 3) << cut;
    EXPECT_EQ(decoder.stats().corrupt, 1u) << cut;
  }
  // A cut frame that still ends in a delimiter costs only itself.
  Decoder decoder;
  const Fed fed = feed(decoder, concat({Bytes(a.begin(), a.begin() + 5), Bytes{0}, b, c}));
  EXPECT_EQ(fed.messages.size(), 2u);
  EXPECT_EQ(decoder.stats().corrupt, 1u);
}

TEST(Decoder, RandomBytesNeverCrashAndEveryBlockIsAccounted) {
  std::mt19937 rng(99);
  std::uniform_int_distribution<int> byte(0, 255);
  std::bernoulli_distribution zero(0.02);
  for (int trial = 0; trial < 50; ++trial) {
    Bytes stream(20000);
    for (auto& b : stream) b = zero(rng) ? 0 : static_cast<std::uint8_t>(byte(rng));
    // Independent count: non-empty runs between delimiters.
    std::uint64_t blocks = 0;
    std::size_t run = 0;
    for (const std::uint8_t b : stream) {
      if (b == 0) {
        if (run > 0) ++blocks;
        run = 0;
      } else {
        ++run;
      }
    }
    Decoder decoder;
    const Fed fed = feed(decoder, stream);
    EXPECT_EQ(decoder.stats().frames + decoder.stats().corrupt + decoder.stats().unknown, blocks)
        << trial;
    EXPECT_EQ(fed.messages.size() + fed.errors.size(), blocks) << trial;
  }
}

TEST(Decoder, GoodFramesSurviveBetweenRandomGarbage) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> byte(0, 255), garbage_length(0, 80);
  Bytes stream;
  for (std::uint16_t s = 0; s < 300; ++s) {
    for (int i = garbage_length(rng); i > 0; --i)
      stream.push_back(static_cast<std::uint8_t>(byte(rng)));
    stream.push_back(0);  // garbage ends; the good frame starts in step
    const Bytes wire = encode(sample_data(s, s, 2));
    stream.insert(stream.end(), wire.begin(), wire.end());
  }
  Decoder decoder;
  const Fed fed = feed(decoder, stream);
  std::vector<int> sequences;
  for (const auto& m : fed.messages) {
    if (const auto* d = std::get_if<Data>(&m); d && d->n == 2 && d->timestamp == d->sequence) {
      sequences.push_back(d->sequence);
    }
  }
  ASSERT_EQ(sequences.size(), 300u);
  for (int s = 0; s < 300; ++s) EXPECT_EQ(sequences[static_cast<std::size_t>(s)], s);
}

// -------------------------------------------------------------- DataTracker

TEST(DataTracker, CountsFramesMissingFromTheSequence) {
  DataTracker tracker;
  for (const int s : {0, 1, 2, 5, 6, 10}) {
    tracker.accept(sample_data(static_cast<std::uint16_t>(s), 0, 1), 1000);
  }
  EXPECT_EQ(tracker.lost_frames(), 2u + 3u);
}

TEST(DataTracker, SequenceWrapIsNoLoss) {
  DataTracker tracker;
  for (const int s : {65533, 65534, 65535, 0, 1}) {
    tracker.accept(sample_data(static_cast<std::uint16_t>(s), 0, 1), 1);
  }
  EXPECT_EQ(tracker.lost_frames(), 0u);
  tracker.accept(sample_data(65535, 9, 1), 1);  // 1 -> 65535: 65533 frames missing
  EXPECT_EQ(tracker.lost_frames(), 65533u);
}

TEST(DataTracker, RepeatedSequenceNumberLosesNothing) {
  DataTracker tracker;
  tracker.accept(sample_data(7, 0, 1), 1);
  tracker.accept(sample_data(7, 1, 1), 1);
  EXPECT_EQ(tracker.lost_frames(), 0u);
}

TEST(DataTracker, UnwrapsTimestamps) {
  DataTracker tracker;
  const double hz = 1e6;
  EXPECT_DOUBLE_EQ(tracker.accept(sample_data(0, 4294967000u, 1), 1000000), 4294967000.0 / hz);
  // Forward across the wrap: 2^32 + 704 ticks.
  EXPECT_DOUBLE_EQ(tracker.accept(sample_data(1, 704u, 1), 1000000), (4294967296.0 + 704.0) / hz);
  // A small step back across the wrap again.
  EXPECT_DOUBLE_EQ(tracker.accept(sample_data(2, 4294967290u, 1), 1000000), 4294967290.0 / hz);
  // Round three more times, each step shorter than half the range.
  tracker.accept(sample_data(3, 2000000000u, 1), 1000000);
  tracker.accept(sample_data(4, 4000000000u, 1), 1000000);
  tracker.accept(sample_data(5, 1000000000u, 1), 1000000);
  tracker.accept(sample_data(6, 3000000000u, 1), 1000000);
  EXPECT_DOUBLE_EQ(tracker.accept(sample_data(7, 5u, 1), 1000000), (3 * 4294967296.0 + 5.0) / hz);
}

TEST(DataTracker, TimeFollowsTheTickRate) {
  DataTracker tracker;
  EXPECT_DOUBLE_EQ(tracker.accept(sample_data(0, 32768u * 3, 1), 32768), 3.0);
}

}  // namespace
}  // namespace moa::io::serial
