// The message of the moa::io::Error a call throws, for tests of bad input.
#pragma once

#include <string>

#include "moa/formats/error.hpp"

namespace moa::test {

/// The what() of the io::Error that f throws, or a marker that none was thrown.
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const io::Error& e) {
    return e.what();
  }
  return "(no io::Error thrown)";
}

}  // namespace moa::test
