// Text made safe for HTML element content and attribute values (& < > " '),
// for the report page and the live dashboard.
#pragma once

#include <string>
#include <string_view>

namespace moa::io {

std::string html(std::string_view text);

}  // namespace moa::io
