// A CAN frame as the codecs see it: an identifier, a length and the payload.
// No OS types here; socketcan.hpp converts to and from struct can(fd)_frame.
#pragma once

#include <array>
#include <cstdint>

namespace springbok::can {

inline constexpr std::uint32_t kStandardIdMask = 0x7FF;
inline constexpr int kClassicMaxLen = 8;
inline constexpr int kFdMaxLen = 64;

struct Frame {
  std::uint32_t id = 0;     // 11-bit identifier (error frames: the CAN_ERR_* class bits)
  std::uint8_t len = 0;     // payload bytes: 0..8 classic, 0..64 CAN FD
  bool fd = false;          // CAN FD frame (bit-rate switch on)
  bool error = false;       // an error frame from the controller (class in id)
  std::array<std::uint8_t, kFdMaxLen> data{};
};

// Why a frame was not accepted. Every decoder returns one; none throws or crashes.
enum class FrameStatus : std::uint8_t {
  ok = 0,
  wrong_dlc = 1,        // length not what the protocol says
  unexpected_id = 2,    // identifier (or MIT byte 0) is no drive of this bus
  bad_value = 3,        // a field is out of its range or not finite
  bad_command = 4,      // unknown command specifier / malformed content
  error_frame = 5,      // an error frame where a data frame was expected
};

const char* to_string(FrameStatus s) noexcept;

}  // namespace springbok::can
