// The one exception type of moa's readers and writers. Its message is one
// line that says where (file, file:line, or file: sensor 'name') and what.
#pragma once

#include <stdexcept>
#include <string>

namespace moa::io {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A file that cannot be opened, written or renamed (as opposed to one whose
/// content is wrong): `moa` exits with kExitIo for it.
class IoError : public Error {
 public:
  using Error::Error;
};

}  // namespace moa::io
