// Internal: the scenario files of examples/scenarios/, compiled in by
// src/sim/CMakeLists.txt (embed_scenarios.cmake writes the definitions).
#pragma once

#include <cstddef>
#include <string_view>

namespace moa::sim::detail {

struct BuiltinScenario {
  std::string_view name;  ///< the file name without .yaml
  std::string_view text;  ///< the file's contents
};

extern const BuiltinScenario kBuiltinScenarios[];
extern const std::size_t kBuiltinScenarioCount;

}  // namespace moa::sim::detail
