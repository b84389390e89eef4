#include "moa/runs/output_path.hpp"

#include <fmt/core.h>

#include <algorithm>

#include "moa/formats/error.hpp"

namespace moa::io {
namespace fs = std::filesystem;

namespace {

fs::path resolved(const fs::path& p) {
  std::error_code ec;
  fs::path r = fs::weakly_canonical(fs::absolute(p, ec), ec);
  return ec ? p.lexically_normal() : r;
}

}  // namespace

void refuse_output_onto_inputs(const fs::path& out, std::string_view option,
                               const std::vector<fs::path>& inputs, std::string_view what) {
  const fs::path o = resolved(out);
  for (const auto& input : inputs) {
    if (input.empty()) continue;
    const fs::path i = resolved(input);
    std::error_code ec;
    const bool same =
        o == i || (fs::exists(o, ec) && fs::exists(i, ec) && fs::equivalent(o, i, ec));
    if (same) {
      throw Error(fmt::format("{} {}: is {}; choose another file", option, out.string(), what));
    }
    // An output directory must not hold an input either (it is replaced).
    const auto [end, ignored] = std::mismatch(o.begin(), o.end(), i.begin(), i.end());
    if (end == o.end() && fs::is_directory(o, ec)) {
      throw Error(fmt::format("{} {}: holds {}, {}; choose another directory", option, out.string(),
                              input.string(), what));
    }
  }
}

}  // namespace moa::io
