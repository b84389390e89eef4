// An output never names an input: a command checks its --out (and every
// other file it writes) against the files it reads before it reads them.
#pragma once

#include <filesystem>
#include <initializer_list>
#include <optional>
#include <string_view>
#include <vector>

namespace moa::io {

/// Throws io::Error ("--out L/mice.csv: is an input of this run (the log's
/// mice.csv); choose another file") when `out` is the same file as one of
/// `inputs` (compared after resolving ., .., and symbolic links), or when
/// `out` is a directory that holds one (for outputs that are directories).
/// `what` names the files in the message ("another output of this run").
void refuse_output_onto_inputs(const std::filesystem::path& out, std::string_view option,
                               const std::vector<std::filesystem::path>& inputs,
                               std::string_view what = "an input of this run");

}  // namespace moa::io
