#include "support/browser.hpp"

#include <sys/wait.h>

#include <cstdlib>

#include "support/run.hpp"

namespace moa::test {

std::optional<std::string> find_chromium() {
  for (const char* name : {"chromium", "chromium-browser", "google-chrome"}) {
    const std::string probe = std::string("command -v ") + name + " >/dev/null 2>&1";
    if (std::system(probe.c_str()) == 0) return std::string(name);
  }
  return std::nullopt;
}

BrowserPage load_page(const std::string& chromium, const std::string& url,
                      const std::filesystem::path& dir, int width, int height, int virtual_time_ms,
                      int timeout_s) {
  // --virtual-time-budget lets the page's timers run before the DOM is
  // dumped; --enable-logging=stderr --v=0 prints the page's console messages
  // as "CONSOLE" lines.
  const std::filesystem::path dom = dir / "dom.html", log = dir / "chromium.log";
  const std::string command =
      "timeout " + std::to_string(timeout_s) + " " + chromium +
      " --headless --no-sandbox --disable-gpu --disable-dev-shm-usage --no-first-run"
      " --user-data-dir=" +
      (dir / "profile").string() + " --window-size=" + std::to_string(width) + "," +
      std::to_string(height) + " --virtual-time-budget=" + std::to_string(virtual_time_ms) +
      " --enable-logging=stderr --v=0 --dump-dom " + url + " >" + dom.string() + " 2>" +
      log.string();
  BrowserPage page;
  const int status = std::system(command.c_str());
  page.exit_code = status < 0          ? -1
                   : WIFEXITED(status) ? WEXITSTATUS(status)
                                       : 128 + WTERMSIG(status);
  page.dom = read_text(dom);
  page.console = read_text(log);
  return page;
}

std::string BrowserPage::failure() const {
  std::string what;
  if (exit_code != 0) {
    what = "chromium exited with " + std::to_string(exit_code) +
           (exit_code == 124 ? " (killed at its time limit)" : "");
  } else if (dom.find("<html") == std::string::npos) {
    what = "chromium exited 0 but dumped no page (" + std::to_string(dom.size()) + " bytes)";
  } else {
    return {};
  }
  return what + "; its log:\n" + console;
}

std::string tag_of(const std::string& dom, const std::string& id) {
  const auto at = dom.find("id=\"" + id + "\"");
  if (at == std::string::npos) return {};
  const auto open = dom.rfind('<', at);
  return dom.substr(open, dom.find('>', at) - open + 1);
}

}  // namespace moa::test
