#include "springbok/app/operator.hpp"

#include <vector>

namespace springbok::app {
namespace {

std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
  return words;
}

ParsedLine error(std::string text) {
  ParsedLine p;
  p.kind = ParsedLine::Kind::error;
  p.error = "error: " + std::move(text);
  return p;
}

ParsedLine command(safety::OperatorCommand c) {
  ParsedLine p;
  p.kind = ParsedLine::Kind::command;
  p.command = c;
  return p;
}

}  // namespace

ParsedLine parse_operator_line(std::string_view line) {
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  if (line.size() > kMaxOperatorLine) return error("line too long (at most 255 bytes)");
  for (const char c : line) {
    const auto u = static_cast<unsigned char>(c);
    if ((u < 0x20 && c != '\t') || u >= 0x7f) return error("non-printable byte in the command");
  }
  const std::vector<std::string_view> words = split_words(line);
  if (words.empty()) return error("empty command (start, stop, mode, reset, status)");
  const std::string_view verb = words[0];
  const std::size_t args = words.size() - 1;
  if (verb == "start" || verb == "stop" || verb == "reset" || verb == "status") {
    if (args != 0) return error(std::string(verb) + " takes no argument");
    if (verb == "status") {
      ParsedLine p;
      p.kind = ParsedLine::Kind::status;
      return p;
    }
    if (verb == "start") return command(safety::OperatorCommand::start);
    if (verb == "stop") return command(safety::OperatorCommand::stop);
    return command(safety::OperatorCommand::reset);
  }
  if (verb == "mode") {
    if (args != 1) return error("mode needs one argument: stand or control");
    if (words[1] == "stand") return command(safety::OperatorCommand::mode_stand);
    if (words[1] == "control") return command(safety::OperatorCommand::mode_control);
    return error("unknown mode '" + std::string(words[1]) + "' (stand or control)");
  }
  return error("unknown command '" + std::string(verb) + "' (start, stop, mode, reset, status)");
}

std::string fault_list(safety::FaultMask faults) {
  if (faults == 0) return "none";
  std::string out;
  for (int bit = 0; bit < safety::fault::kCount; ++bit) {
    if ((faults & (1u << bit)) == 0) continue;
    if (!out.empty()) out += ',';
    out += safety::fault_name(bit);
  }
  return out;
}

}  // namespace springbok::app
