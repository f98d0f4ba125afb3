// Runs a command line through the shell and keeps what it printed (standard output and error
// together) and its exit status: the tests that run a command-line tool.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace springbok::test {

struct CommandRun {
  int exit_code = -1;  // -1: it did not start, or did not exit normally
  std::string out;     // standard output and standard error
};

inline CommandRun run_command(const std::string& command_line) {
  CommandRun r;
  std::FILE* p = ::popen((command_line + " 2>&1").c_str(), "r");
  if (p == nullptr) return r;
  char buf[512];
  while (std::fgets(buf, sizeof buf, p) != nullptr) r.out += buf;
  const int status = ::pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// A program of this build (build/<preset>/bin), under the build's emulator when it is
// cross-built (`emulator`: the test's SPRINGBOK_TEST_EMULATOR, "" natively).
inline CommandRun run_program(const std::string& emulator, const std::string& program, const std::string& args) {
  return run_command((emulator.empty() ? "" : emulator + " ") + std::string(SPRINGBOK_BIN_DIR) + "/" + program + " " +
                     args);
}

}  // namespace springbok::test
