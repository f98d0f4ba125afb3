#include "browser.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <vector>

#include "view_page.hpp"

namespace springbok::view {
namespace {

// A fresh profile folder, removed when the run ends.
struct TempDir {
  std::filesystem::path path;
  TempDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "springbok-view-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) throw Error("cannot make a temporary folder for the browser's profile");
    path = pattern;
  }
  ~TempDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
};

std::string file_url(const std::filesystem::path& page, const std::string& fragment) {
  if (!std::filesystem::is_regular_file(page)) throw Error(fmt::format("{}: no such page", page.string()));
  std::string url = "file://" + std::filesystem::absolute(page).lexically_normal().string();
  if (!fragment.empty()) url += "#" + fragment;
  return url;
}

// Runs the browser headless on `url` with `extra` flags; its stdout is returned, its stderr
// (WebGL's and the sandbox's chatter) dropped. Fails on a non-zero exit.
std::string run_browser(const BrowserRun& b, const std::string& url, const std::vector<std::string>& extra) {
  TempDir profile;
  // Flags: headless WebGL through SwiftShader (no GPU), and none of the browser's own network
  // traffic (robots and CI machines are often offline).
  std::vector<std::string> args = {
      b.browser.string(), "--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
      "--disable-quic", "--no-first-run", "--disable-background-networking", "--disable-component-update",
      "--disable-sync", "--hide-scrollbars", "--mute-audio", "--allow-file-access-from-files",
      "--user-data-dir=" + profile.path.string(), fmt::format("--window-size={},{}", b.width_px, b.height_px)};
  args.insert(args.end(), extra.begin(), extra.end());
  args.push_back(url);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);

  int out_pipe[2];
  if (::pipe(out_pipe) != 0) throw Error("cannot make a pipe for the browser");
  const pid_t pid = ::fork();
  if (pid < 0) throw Error("cannot start the browser (fork)");
  if (pid == 0) {
    ::dup2(out_pipe[1], STDOUT_FILENO);
    const int null = ::open("/dev/null", O_WRONLY);
    if (null >= 0) ::dup2(null, STDERR_FILENO);
    ::close(out_pipe[0]);
    ::close(out_pipe[1]);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  ::close(out_pipe[1]);
  std::string out;
  char buf[65536];
  for (ssize_t n; (n = ::read(out_pipe[0], buf, sizeof buf)) != 0;) {
    if (n < 0) {
      if (errno == EINTR) continue;
      break;
    }
    out.append(buf, static_cast<std::size_t>(n));
  }
  ::close(out_pipe[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw Error(fmt::format("{} on {} failed (exit status {})", b.browser.string(), url,
                            WIFEXITED(status) ? WEXITSTATUS(status) : -1));
  }
  return out;
}

}  // namespace

std::filesystem::path find_browser(const std::string& requested) {
  if (!requested.empty()) {
    if (::access(requested.c_str(), X_OK) != 0) throw Error(fmt::format("--browser {}: not an executable", requested));
    return requested;
  }
  if (const char* env = std::getenv("SPRINGBOK_BROWSER"); env != nullptr && *env != '\0') {
    if (::access(env, X_OK) != 0) throw Error(fmt::format("SPRINGBOK_BROWSER={}: not an executable", env));
    return env;
  }
  const char* path = std::getenv("PATH");
  const std::string dirs = path != nullptr ? path : "/usr/bin:/bin";
  for (const char* name : {"chromium", "chromium-browser", "google-chrome"}) {
    std::size_t start = 0;
    while (start <= dirs.size()) {
      const std::size_t colon = dirs.find(':', start);
      const std::string dir = dirs.substr(start, colon == std::string::npos ? std::string::npos : colon - start);
      const std::filesystem::path candidate = std::filesystem::path(dir.empty() ? "." : dir) / name;
      if (::access(candidate.c_str(), X_OK) == 0) return candidate;
      if (colon == std::string::npos) break;
      start = colon + 1;
    }
  }
  throw Error("no browser: none of chromium, chromium-browser, google-chrome on PATH (Debian: apt-get install "
              "chromium; or give --browser or SPRINGBOK_BROWSER)");
}

void screenshot(const BrowserRun& b, const std::filesystem::path& page, const std::string& fragment,
                const std::filesystem::path& png) {
  std::error_code ignored;
  std::filesystem::remove(png, ignored);
  run_browser(b, file_url(page, fragment),
              {"--virtual-time-budget=10000", "--screenshot=" + std::filesystem::absolute(png).string()});
  if (!std::filesystem::is_regular_file(png) || std::filesystem::file_size(png) == 0) {
    throw Error(fmt::format("{}: the browser wrote no screenshot", png.string()));
  }
}

std::string dump_dom(const BrowserRun& b, const std::filesystem::path& page, const std::string& fragment) {
  return run_browser(b, file_url(page, fragment), {"--virtual-time-budget=10000", "--dump-dom"});
}

std::string dump_dom_url(const BrowserRun& b, const std::string& url, int virtual_ms) {
  return run_browser(b, url, {fmt::format("--virtual-time-budget={}", virtual_ms), "--dump-dom"});
}

}  // namespace springbok::view
