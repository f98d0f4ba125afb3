// springbok-can-up: brings up every CAN interface of a configuration's `can:`
// section, as the firmware will use them (the systemd unit runs it as root before
// `springbok`; one place for the bus list: the config). Per interface:
//   ip link set IF down
//   ip link set IF type can bitrate B [dbitrate D fd on] restart-ms 0
//   ip link set IF up
// restart-ms 0: no automatic restart after bus-off (CAN.md 4: recovery is an
// operator action). A virtual bus (vcan*) has no bit timing: only `up`.
// --dry-run prints the commands instead; --ip names the ip(8) binary.
#include <spawn.h>
#include <sys/wait.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include "springbok/can/config_yaml.hpp"

extern char** environ;

namespace {

std::vector<std::vector<std::string>> link_commands(const springbok::can::CanConfig& can) {
  std::vector<std::vector<std::string>> out;
  std::set<std::string> seen;
  for (const springbok::can::BusConfig& bus : can.buses) {
    if (!seen.insert(bus.interface).second) continue;
    const bool virtual_bus = bus.interface.rfind("vcan", 0) == 0;
    if (!virtual_bus) {
      out.push_back({"link", "set", bus.interface, "down"});
      std::vector<std::string> type{"link", "set", bus.interface, "type", "can", "bitrate", std::to_string(bus.bitrate)};
      if (bus.fd) type.insert(type.end(), {"dbitrate", std::to_string(bus.data_bitrate), "fd", "on"});
      type.insert(type.end(), {"restart-ms", "0"});
      out.push_back(type);
    }
    out.push_back({"link", "set", bus.interface, "up"});
  }
  return out;
}

// Runs `ip args...`; returns its exit status (127: could not start it).
int run(const std::string& ip, const std::vector<std::string>& args) {
  std::vector<std::string> all{ip};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawn(&pid, ip.c_str(), nullptr, nullptr, argv.data(), environ) != 0) return 127;
  int status = 0;
  if (waitpid(pid, &status, 0) < 0) return 127;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

std::string joined(const std::string& ip, const std::vector<std::string>& args) {
  std::string s = ip;
  for (const std::string& a : args) s += " " + a;
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"springbok-can-up: bring up the CAN interfaces of a springbok configuration"};
  std::string config_path, ip = "/usr/sbin/ip";
  bool dry_run = false;
  app.add_option("--config", config_path, "robot configuration (YAML) with a can: section")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--ip", ip, "the ip(8) binary");
  app.add_flag("--dry-run", dry_run, "print the commands, run nothing");
  CLI11_PARSE(app, argc, argv);

  const springbok::can::ConfigResult can = springbok::can::load_can_config_file(config_path);
  if (!can.ok) {
    std::fprintf(stderr, "springbok-can-up: config error: %s\n", can.error.c_str());
    return 1;
  }
  for (const std::vector<std::string>& args : link_commands(can.config)) {
    std::printf("%s\n", joined(ip, args).c_str());
    std::fflush(stdout);
    if (dry_run) continue;
    if (const int status = run(ip, args); status != 0) {
      std::fprintf(stderr, "springbok-can-up: '%s' failed (exit %d)\n", joined(ip, args).c_str(), status);
      return 1;
    }
  }
  return 0;
}
