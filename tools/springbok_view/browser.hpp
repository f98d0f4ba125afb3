// Headless Chromium for the viewer's page: a screenshot of it, or the DOM it ends with (what
// the browser test reads back). Start-up tooling: problems are exceptions.
#pragma once

#include <filesystem>
#include <string>

namespace springbok::view {

// The browser: `requested` if given, else $SPRINGBOK_BROWSER, else chromium (Debian's package)
// or chromium-browser / google-chrome on PATH. Throws Error naming what it looked for.
std::filesystem::path find_browser(const std::string& requested);

struct BrowserRun {
  std::filesystem::path browser;
  int width_px = 1280;
  int height_px = 720;
};

// Loads `page` (a file, with `fragment` after '#': "t=2.5") headless and writes its PNG to `png`.
void screenshot(const BrowserRun& b, const std::filesystem::path& page, const std::string& fragment,
                const std::filesystem::path& png);

// Loads `page` headless and returns the DOM after its scripts ran (--dump-dom).
std::string dump_dom(const BrowserRun& b, const std::filesystem::path& page, const std::string& fragment);
// The DOM of a page served at `url` (the live page), `virtual_ms` of the page's time after its load.
std::string dump_dom_url(const BrowserRun& b, const std::string& url, int virtual_ms);

}  // namespace springbok::view
