// springbok-dyn IN OUT: reads q, v, vdot, tau_aba from a state file
// (tests/data/reference/FORMAT.md) and writes every block of the format
// computed by springbok::dyn. A malformed IN gives a message naming the line,
// exit status 1, and no OUT.
#include <cstdio>
#include <exception>
#include <string>

#include <CLI/CLI.hpp>

#include "state_file.hpp"

int main(int argc, char** argv) {
  CLI::App app{"springbok-dyn: rigid-body dynamics of one state file (FORMAT.md v1)"};
  std::string in_path, out_path;
  app.add_option("IN", in_path, "input state file (q, v, vdot, tau_aba are read)")->required();
  app.add_option("OUT", out_path, "output state file (every block, %.17g)")->required();
  CLI11_PARSE(app, argc, argv);
  try {
    namespace sf = springbok::state_file;
    const sf::DynamicsInput input = sf::dynamics_input(sf::read(in_path));
    const std::string text =
        sf::format(sf::compute_blocks(input), "springbok-dyn output, format v1 (see FORMAT.md); input: " + in_path);
    sf::write_atomically(out_path, text);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "springbok-dyn: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
