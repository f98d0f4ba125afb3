#pragma once
// springbok::isa: the instruction-set level the hot kernels run at.
//
// A package must run on every machine of its architecture, so the shipped build targets the
// baseline (-march=x86-64: SSE2). Eigen picks its SIMD width when it is compiled, so a
// baseline build leaves AVX2 and FMA unused on the robot's computer. The portable x86-64
// build therefore compiles the hot kernels (the dynamics sweeps, the whole-body controller's
// tick with its QP, the base estimator's update) once more per level below, into objects
// whose every symbol but the level's table is private to them (toolchain/springbok_isa.cmake:
// no template of another level can stand in for theirs), and each kernel's public function
// calls the copy of active() through that table:
//
//   level      -march       what it adds                        kernels
//   baseline   x86-64       SSE2 (or the build's -march)        always
//   x86_64_v3  x86-64-v3    AVX2, FMA, BMI2 (Haswell, Zen)       portable x86-64 builds
//   x86_64_v4  x86-64-v4    AVX-512 F/BW/CD/DQ/VL (Skylake-SP)   portable x86-64 builds
//
// The level is chosen once, before main(): the widest one compiled in that the CPU supports
// (CPUID and the OS's saved state, via __builtin_cpu_supports), or the one the environment's
// SPRINGBOK_ISA names (x86-64, x86-64-v3, x86-64-v4: to compare levels, or to rule one out).
// A tick only reads it. Fixed-size Eigen objects are laid out as the baseline lays them out
// (EIGEN_MAX_STATIC_ALIGN_BYTES=16 in every level's kernels), so all levels work on the
// same objects.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace springbok::isa {

enum class Level : std::uint8_t { baseline, x86_64_v3, x86_64_v4 };
inline constexpr int kLevels = 3;

// "x86-64-v3"; the baseline is named as the build's -march ("x86-64", "armv8-a", "native").
const char* name(Level level) noexcept;
// The inverse of name(); nullopt for any other text.
std::optional<Level> parse(std::string_view text) noexcept;

// This binary holds kernels compiled for `level`.
bool compiled(Level level) noexcept;
// The CPU (and the OS) can run code compiled for `level`.
bool cpu_supports(Level level) noexcept;
// The widest level compiled in that the CPU supports.
Level best() noexcept;

// The level the kernels run at. rt: no alloc, no block (one relaxed atomic load)
Level active() noexcept;
// Runs the kernels at `level` from the next call on; false, and nothing changes, when it is
// not compiled in or the CPU cannot run it. Start-up, tests and benchmarks: never while
// another thread ticks.
bool select(Level level) noexcept;

// What SPRINGBOK_ISA said when it was not a level this binary can run (the level then
// stayed best()); empty when it was unset or taken. Start-up code reports it.
const std::string& environment_error() noexcept;

// One line for --version and logs: "kernels x86-64-v3 (compiled: x86-64 x86-64-v3
// x86-64-v4; CPU: x86-64-v3)".
std::string describe();

// A library's kernels per level (its src/dispatch.hpp): a table of function pointers, the
// baseline's in the library, each other level's defined by that level's object (its
// src/isa/entry.cpp, in namespace isa_<level>). The one of active(). rt: no alloc, no block
template <class Table>
const Table& active_table(const Table& baseline, const Table& x86_64_v3, const Table& x86_64_v4) noexcept {
  switch (active()) {
    case Level::x86_64_v3: return x86_64_v3;
    case Level::x86_64_v4: return x86_64_v4;
    case Level::baseline: break;
  }
  return baseline;
}

}  // namespace springbok::isa

// Declares, in the library's namespace, the tables of type Table that the levels' objects
// define; SPRINGBOK_ISA_ACTIVE_TABLE(baseline) is then active()'s table there.
#ifdef SPRINGBOK_ISA_VARIANTS
#define SPRINGBOK_ISA_ACTIVE_TABLE(baseline) \
  ::springbok::isa::active_table(baseline, isa_x86_64_v3::kKernels, isa_x86_64_v4::kKernels)
#define SPRINGBOK_ISA_LEVEL_TABLES(Table) \
  namespace isa_x86_64_v3 {               \
  extern const Table kKernels;            \
  }                                       \
  namespace isa_x86_64_v4 {               \
  extern const Table kKernels;            \
  }
#else
#define SPRINGBOK_ISA_ACTIVE_TABLE(baseline) (baseline)
#define SPRINGBOK_ISA_LEVEL_TABLES(Table)
#endif
