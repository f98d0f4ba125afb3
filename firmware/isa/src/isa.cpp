#include "springbok/isa/isa.hpp"

#include <atomic>
#include <cstdlib>

namespace springbok::isa {
namespace {

Level choose_at_start_up(std::string& error) noexcept {
  const char* env = std::getenv("SPRINGBOK_ISA");
  if (env == nullptr || *env == '\0') return best();
  const std::optional<Level> asked = parse(env);
  if (!asked) {
    error = std::string("SPRINGBOK_ISA: '") + env + "' is no level (x86-64, x86-64-v3, x86-64-v4)";
  } else if (!compiled(*asked)) {
    error = std::string("SPRINGBOK_ISA: no kernels for ") + env + " in this build";
  } else if (!cpu_supports(*asked)) {
    error = std::string("SPRINGBOK_ISA: this CPU cannot run ") + env;
  } else {
    return *asked;
  }
  return best();
}

std::string& env_error() {
  static std::string error;
  return error;
}

std::atomic<Level>& active_level() {
  static std::atomic<Level> level{choose_at_start_up(env_error())};
  return level;
}

// Chosen before main(), never in a tick.
[[maybe_unused]] const Level kChosenAtStartUp = active_level().load();

}  // namespace

const char* name(Level level) noexcept {
  switch (level) {
    case Level::baseline: return SPRINGBOK_ISA_BASELINE_NAME;
    case Level::x86_64_v3: return "x86-64-v3";
    case Level::x86_64_v4: return "x86-64-v4";
  }
  return "unknown";
}

std::optional<Level> parse(std::string_view text) noexcept {
  for (int l = 0; l < kLevels; ++l) {
    if (text == name(static_cast<Level>(l))) return static_cast<Level>(l);
  }
  return std::nullopt;
}

bool compiled(Level level) noexcept {
#ifdef SPRINGBOK_ISA_VARIANTS
  return level == Level::baseline || level == Level::x86_64_v3 || level == Level::x86_64_v4;
#else
  return level == Level::baseline;
#endif
}

bool cpu_supports(Level level) noexcept {
  switch (level) {
    case Level::baseline: return true;  // what the binary was built for
#if defined(__x86_64__)
    case Level::x86_64_v3: return __builtin_cpu_supports("x86-64-v3") != 0;
    case Level::x86_64_v4: return __builtin_cpu_supports("x86-64-v4") != 0;
#else
    case Level::x86_64_v3:
    case Level::x86_64_v4: return false;
#endif
  }
  return false;
}

Level best() noexcept {
  for (int l = kLevels - 1; l > 0; --l) {
    const auto level = static_cast<Level>(l);
    if (compiled(level) && cpu_supports(level)) return level;
  }
  return Level::baseline;
}

Level active() noexcept { return active_level().load(std::memory_order_relaxed); }

bool select(Level level) noexcept {
  if (!compiled(level) || !cpu_supports(level)) return false;
  active_level().store(level, std::memory_order_relaxed);
  return true;
}

const std::string& environment_error() noexcept {
  (void)active_level();
  return env_error();
}

std::string describe() {
  std::string compiled_levels, cpu = name(Level::baseline);
  for (int l = 0; l < kLevels; ++l) {
    const auto level = static_cast<Level>(l);
    if (compiled(level)) compiled_levels += std::string(compiled_levels.empty() ? "" : " ") + name(level);
    if (l > 0 && cpu_supports(level)) cpu = name(level);
  }
  return std::string("kernels ") + name(active()) + " (compiled: " + compiled_levels + "; CPU: " + cpu + ")";
}

}  // namespace springbok::isa
