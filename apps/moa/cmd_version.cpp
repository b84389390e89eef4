#include <fmt/core.h>
#include <Eigen/Core>

#include "commands.hpp"

namespace moa::cli {

void add_version(CLI::App& app, Action& action) {
  auto* cmd = app.add_subcommand("version", "Print moa's version and what it was built with");
  cmd->callback([&action] {
    action = [] {
      fmt::print("moa {}\n", MOA_VERSION);
      fmt::print("Eigen {}.{}.{}, compiler {}\n", EIGEN_WORLD_VERSION, EIGEN_MAJOR_VERSION,
                 EIGEN_MINOR_VERSION, __VERSION__);
      return 0;
    };
  });
}

}  // namespace moa::cli
