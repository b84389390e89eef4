#include "sensor_binding.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "moa/formats/config.hpp"
#include "moa/formats/csv.hpp"
#include "moa/formats/error.hpp"

namespace moa::cli {

std::vector<SensorBinding> parse_bindings(const std::vector<std::string>& args,
                                          std::string_view flag) {
  std::vector<SensorBinding> bindings;
  for (const auto& arg : args) {
    const std::size_t eq = arg.find('=');
    if (eq == std::string::npos) {
      throw io::Error(fmt::format("{} {}: expected NAME=PATH", flag, arg));
    }
    SensorBinding binding{arg.substr(0, eq), arg.substr(eq + 1)};
    if (binding.name.empty() || binding.target.empty()) {
      throw io::Error(fmt::format("{} {}: expected NAME=PATH, both non-empty", flag, arg));
    }
    // The name becomes a mice.csv field and an odometry.csv column.
    if (!io::is_valid_sensor_name(binding.name)) {
      throw io::Error(fmt::format("{} {}: invalid sensor name '{}': a name is {}", flag,
                                  io::printable(arg), io::excerpt(binding.name),
                                  io::kSensorNameRule));
    }
    const bool duplicate = std::any_of(bindings.begin(), bindings.end(),
                                       [&](const auto& b) { return b.name == binding.name; });
    if (duplicate) throw io::Error(fmt::format("{}: sensor '{}' given twice", flag, binding.name));
    bindings.push_back(std::move(binding));
  }
  return bindings;
}

}  // namespace moa::cli
