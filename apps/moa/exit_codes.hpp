// The exit codes of `moa` (docs/formats/cli.md): the CLI's, not the library's.
// The library throws io::Error (bad input) and io::IoError (a file that
// cannot be opened, written or renamed); main() maps them to these codes.
#pragma once

namespace moa::cli {

/// The exit codes of `moa` (docs/formats/cli.md).
enum ExitCode : int {
  kExitOk = 0,
  kExitBadInput = 1,  ///< malformed file, invalid value, refused data
  kExitUsage = 2,     ///< unknown command or option, missing or malformed argument
  kExitIo = 3,        ///< a file that cannot be opened, written or renamed
  kExitInternal = 4,  ///< a bug: an unexpected exception
};

}  // namespace moa::cli
