#include "moa/runs/option_error.hpp"

namespace moa::io {
namespace {

std::string render_template(std::string_view text,
                            const std::function<std::string(std::string_view)>& name_of) {
  std::string out;
  std::size_t at = 0;
  while (at < text.size()) {
    const std::size_t open = text.find('{', at);
    if (open == std::string_view::npos) break;
    out.append(text.substr(at, open - at));
    if (open + 1 < text.size() && text[open + 1] == '{') {  // "{{": a literal brace
      out += '{';
      at = open + 2;
      continue;
    }
    const std::size_t close = text.find('}', open);
    if (close == std::string_view::npos) {
      at = open;
      break;
    }
    out += name_of(text.substr(open + 1, close - open - 1));
    at = close + 1;
  }
  out.append(text.substr(std::min(at, text.size())));
  return out;
}

}  // namespace

std::string OptionError::literal(std::string_view value) {
  std::string out;
  for (const char c : value) {
    out += c;
    if (c == '{') out += '{';
  }
  return out;
}

OptionError::OptionError(std::string message_template)
    : Error(render_template(message_template, [](std::string_view n) { return std::string(n); })),
      template_(std::move(message_template)) {}

std::string OptionError::render(const std::function<std::string(std::string_view)>& name_of) const {
  return render_template(template_, name_of);
}

}  // namespace moa::io
