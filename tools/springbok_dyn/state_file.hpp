// Reading and writing RBD state files (tests/data/reference/FORMAT.md):
// '#' comments, then blocks "<name> <rows> <cols>" each followed by <rows>
// lines of <cols> numbers. Start-up / tool code: throws StateFileError with a
// message "<file>:<line>: <what is wrong>".
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "springbok/dynamics/dynamics.hpp"

namespace springbok::state_file {

class StateFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Block {
  std::string name;
  int rows = 0;
  int cols = 0;
  std::vector<double> values;  // row-major
  int header_line = 0;         // 1-based line of "<name> <rows> <cols>"
};

struct StateFile {
  std::string source;  // file name, for messages
  std::vector<Block> blocks;
  std::vector<std::string> joint_names;  // format v2's `joints` block (an empty block in `blocks`)

  // The block called `name`, or nullptr.
  const Block* find(const std::string& name) const;
  // The block called `name` with exactly this shape; throws naming the line.
  const Block& require(const std::string& name, int rows, int cols) const;
};

// Parses the text of a state file. Every number must be finite.
StateFile parse(const std::string& text, const std::string& source);
StateFile read(const std::string& path);

// The inputs springbok-dyn takes from a state file.
struct DynamicsInput {
  VecNq q;
  VecNv v, vdot, tau_aba;
};

// Smallest base-quaternion norm accepted: CONVENTIONS.md takes R_WB from the quaternion
// "normalise first", so any other norm is normalised (the dynamics do); one this small
// has no direction to normalise to.
inline constexpr double kMinQuaternionNorm = 1e-6;

// Extracts and validates q (1x26, a quaternion of norm >= kMinQuaternionNorm), v, vdot,
// tau_aba (1x25).
DynamicsInput dynamics_input(const StateFile& file);

// Every block of the format, computed by springbok::dyn, in the format's order.
std::vector<Block> compute_blocks(const DynamicsInput& in);

// Formats blocks (%.17g) after a '#' comment line.
std::string format(const std::vector<Block>& blocks, const std::string& comment);

// Writes `text` to `path` through a temporary file in the same folder and a
// rename, so `path` never holds a partial file.
void write_atomically(const std::string& path, const std::string& text);

}  // namespace springbok::state_file
