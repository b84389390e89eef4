#include "moa/sources/otos_registers.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace moa::io::otos {
namespace {

std::int16_t le16(std::uint8_t low, std::uint8_t high) {
  return static_cast<std::int16_t>(static_cast<std::uint16_t>(low | (high << 8)));
}

std::int16_t nearest_int16(double value) {
  constexpr double lo = std::numeric_limits<std::int16_t>::min();
  constexpr double hi = std::numeric_limits<std::int16_t>::max();
  if (std::isnan(value)) return 0;
  return static_cast<std::int16_t>(std::clamp(std::round(value), lo, hi));
}

bool at_full_scale(std::int16_t raw) {
  return raw == std::numeric_limits<std::int16_t>::max() ||
         raw == std::numeric_limits<std::int16_t>::min();
}

}  // namespace

RawTriple decode_raw(std::span<const std::uint8_t, 6> b) {
  return {le16(b[0], b[1]), le16(b[2], b[3]), le16(b[4], b[5])};
}

void encode_raw(const RawTriple& raw, std::span<std::uint8_t, 6> b) {
  const std::int16_t values[3] = {raw.x, raw.y, raw.h};
  for (std::size_t i = 0; i < 3; ++i) {
    const auto u = static_cast<std::uint16_t>(values[i]);
    b[2 * i] = static_cast<std::uint8_t>(u & 0xFFu);
    b[2 * i + 1] = static_cast<std::uint8_t>(u >> 8);
  }
}

Triple to_si(const RawTriple& raw, const TripleScale& scale) {
  return {Vec2(raw.x * scale.xy, raw.y * scale.xy), raw.h * scale.h};
}

RawTriple to_raw(const Triple& value, const TripleScale& scale) {
  return {nearest_int16(value.xy.x() / scale.xy), nearest_int16(value.xy.y() / scale.xy),
          nearest_int16(value.h / scale.h)};
}

double scalar_from_register(std::uint8_t value) {
  return 1.0 + kScalarLsb * static_cast<std::int8_t>(value);
}

std::optional<std::uint8_t> scalar_register(double scalar) {
  // The bounds with a hair of tolerance: 0.872 and 1.127 are themselves steps.
  constexpr double tolerance = 1e-9;
  if (!(scalar >= kMinScalar - tolerance && scalar <= kMaxScalar + tolerance)) return std::nullopt;
  const auto steps = static_cast<int>(std::lround((scalar - 1.0) / kScalarLsb));
  return static_cast<std::uint8_t>(static_cast<std::int8_t>(steps));
}

Reading decode_poll(std::span<const std::uint8_t, kPollBytes> bytes) {
  const RawTriple position = decode_raw(bytes.subspan<1, 6>());
  const RawTriple velocity = decode_raw(bytes.subspan<7, 6>());
  Reading r;
  r.status = bytes[0];
  const Triple p = to_si(position, kPositionScale);
  const Triple v = to_si(velocity, kVelocityScale);
  r.position = p.xy;
  r.heading = p.h;
  r.velocity = v.xy;
  r.rate = v.h;
  r.rate_saturated = at_full_scale(velocity.h);
  return r;
}

Vec2 body_velocity(const Reading& reading) {
  return rotation(reading.heading).transpose() * reading.velocity;
}

}  // namespace moa::io::otos
