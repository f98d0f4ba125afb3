// libFuzzer: arbitrary records into the telemetry encoder (app::telemetry_json): every
// double from 8 input bytes (NaN, infinities, subnormals, 1e308 included), every integer and
// flag from the bytes after. The datagram must be empty (a non-finite timestamp) or one flat
// JSON object, {"timestamp":N(,"name":N)*}, whose every number parses whole and is finite,
// and it must fit one UDP datagram. Under ASan any write past a buffer aborts the run.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>

#include "springbok/app/telemetry.hpp"

using namespace springbok;

namespace {

struct Bytes {
  const std::uint8_t* data;
  std::size_t size;
  std::size_t at = 0;
  std::uint8_t byte() { return at < size ? data[at++] : 0; }
  double number() {
    std::uint64_t bits = 0;
    for (int i = 0; i < 8; ++i) bits |= std::uint64_t{byte()} << (8 * i);
    double v;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }
  template <std::size_t N>
  void numbers(std::array<double, N>& out) {
    for (double& v : out) v = number();
  }
};

[[noreturn]] void fail(const char* why, const std::string& json) {
  __builtin_fprintf(stderr, "fuzz_telemetry: %s: %s\n", why, json.c_str());
  std::abort();
}

// {"timestamp":N(,"name":N)*}: names of [a-z0-9_], numbers strtod parses whole, finite.
void check_flat_json(const std::string& json) {
  if (json.rfind("{\"timestamp\":", 0) != 0 || json.back() != '}') fail("not a flat object", json);
  std::size_t at = 1;
  bool first = true;
  while (at < json.size() - 1) {
    if (!first) {
      if (json[at] != ',') fail("expected ,", json);
      ++at;
    }
    first = false;
    if (json[at] != '"') fail("expected a name", json);
    const std::size_t close = json.find('"', at + 1);
    if (close == std::string::npos || close == at + 1) fail("bad name", json);
    for (std::size_t i = at + 1; i < close; ++i) {
      const char c = json[i];
      if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) fail("bad name character", json);
    }
    if (json[close + 1] != ':') fail("expected :", json);
    at = close + 2;
    const std::size_t end = json.find_first_of(",}", at);
    if (end == std::string::npos || end == at) fail("missing number", json);
    const std::string token = json.substr(at, end - at);
    char* parsed_to = nullptr;
    const double v = std::strtod(token.c_str(), &parsed_to);
    if (parsed_to != token.c_str() + token.size() || !std::isfinite(v)) fail("bad number", json);
    if (token.find_first_of("nN") != std::string::npos) fail("nan/inf spelled", json);
    at = end;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Bytes in{data, size};
  app::TelemetryRecord r;
  r.timestamp_s = in.number();
  r.tick = 0;
  for (int i = 0; i < 8; ++i) r.tick |= std::uint64_t{in.byte()} << (8 * i);
  r.mode = in.byte();
  r.faults = static_cast<std::uint32_t>(in.byte()) | (static_cast<std::uint32_t>(in.byte()) << 24);
  r.compute_us = in.number();
  r.wake_latency_us = in.number();
  const std::uint8_t flags = in.byte();
  r.wbc = (flags & 1) != 0;
  r.engaged = (flags & 2) != 0;
  r.tick_status = in.byte();
  r.qp_status = in.byte();
  r.qp_iterations = static_cast<std::int32_t>(static_cast<std::uint32_t>(in.byte()) << 24 | in.byte());
  in.numbers(r.base_position_m);
  in.numbers(r.base_quaternion_xyzw);
  in.numbers(r.base_rpy_rad);
  in.numbers(r.base_velocity_m_s);
  in.numbers(r.base_rate_rad_s);
  in.numbers(r.hand_position_m);
  in.numbers(r.hand_quaternion_xyzw);
  in.numbers(r.base_rest_m);
  in.numbers(r.hand_rest_m);
  in.numbers(r.hand_rest_quaternion_xyzw);
  in.numbers(r.base_displacement_m);
  in.numbers(r.hand_displacement_m);
  in.numbers(r.external_force_n);
  in.numbers(r.external_torque_nm);
  for (auto& f : r.foot_force_n) in.numbers(f);
  for (bool& s : r.stance) s = (in.byte() & 1) != 0;
  in.numbers(r.q_rad);
  in.numbers(r.qd_rad_s);
  in.numbers(r.tau_nm);

  const std::string json = app::telemetry_json(r);
  if (json.empty()) {
    if (std::isfinite(r.timestamp_s)) fail("empty datagram for a finite timestamp", json);
    return 0;
  }
  if (json.size() > 65507) fail("larger than one UDP datagram", json);
  check_flat_json(json);
  return 0;
}
