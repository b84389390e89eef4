// Headless Chromium for the tests of the pages moa writes (the report) and
// serves (the live dashboard): find it, let it load a page, run its script
// and dump the DOM with the console's messages.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

namespace moa::test {

/// The first of chromium, chromium-browser, google-chrome on the PATH.
std::optional<std::string> find_chromium();

struct BrowserPage {
  int exit_code = -1;   ///< Chromium's (0: loaded and dumped)
  std::string dom;      ///< the DOM after the script ran
  std::string console;  ///< Chromium's log; the page's console lines contain "CONSOLE"
  /// "" when Chromium exited 0 and dumped a page (an <html> element), else
  /// what went wrong with Chromium's exit code and its log: a test asserts
  /// `page.failure().empty()` before it reads the DOM, so that an empty dump
  /// is a failure that shows why, never a pass.
  std::string failure() const;
};

/// Loads `url` in `chromium` (headless, a fresh profile under `dir`), lets
/// its timers run for `virtual_time_ms` of virtual time, and dumps the DOM;
/// killed after `timeout_s` of real time.
BrowserPage load_page(const std::string& chromium, const std::string& url,
                      const std::filesystem::path& dir, int width, int height, int virtual_time_ms,
                      int timeout_s);

/// The opening tag of the element with id `id` in a dumped DOM ("" if none).
std::string tag_of(const std::string& dom, const std::string& id);

}  // namespace moa::test
