// Building and reading frames in the CAN tests.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <vector>

#include "springbok/can/frame.hpp"

namespace springbok::can::frame_util {

inline Frame frame_of(std::uint32_t id, std::initializer_list<std::uint8_t> data) {
  Frame f;
  f.id = id;
  f.len = static_cast<std::uint8_t>(data.size());
  int i = 0;
  for (std::uint8_t b : data) f.data[i++] = b;
  return f;
}

// The payload bytes (len of them), comparable with a std::vector<int> literal.
inline std::vector<int> bytes(const Frame& f) { return std::vector<int>(f.data.begin(), f.data.begin() + f.len); }

}  // namespace springbok::can::frame_util
