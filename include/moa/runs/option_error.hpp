// An option a front end gave that the library refuses, worded without the
// front end's names for its options: the message is a template in which
// each option appears as {name} (the field of the options struct, e.g.
// "{estimator} wheels and {no_wheels} exclude each other"). what() names
// them as they are ("{{" is a literal brace); the CLI renders it with its flags ("--estimator
// wheels and --no-wheels exclude each other"), Python with its keywords.
#pragma once

#include <functional>
#include <string>
#include <string_view>

#include "moa/formats/error.hpp"

namespace moa::io {

class OptionError : public Error {
 public:
  explicit OptionError(std::string message_template);
  /// `value` (a name from a file, a value given) for a template: its braces
  /// doubled, so that they are not taken for an option.
  static std::string literal(std::string_view value);
  /// The message with each {name} replaced by `name_of(name)`.
  std::string render(const std::function<std::string(std::string_view name)>& name_of) const;
  const std::string& message_template() const { return template_; }

 private:
  std::string template_;
};

}  // namespace moa::io
