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

}  // namespace moa::io
