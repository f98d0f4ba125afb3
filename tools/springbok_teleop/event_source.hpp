// Where springbok-teleop's input events come from: a Linux input device read with libevdev,
// or a recorded stream (a text file, replayed at its own pace). The stream format, one item
// per line ('#' starts a comment; names as linux/input-event-codes.h spells them):
//
//   axis ABS_X -32768 32767        an axis's range (the device's absinfo)
//   0.120 EV_KEY BTN_TL 1          an event at 0.120 s from the stream's start
//   2.500 unplug                   the pad is pulled out (also at the end of the stream)
//
// `springbok-teleop --device D --record F` writes a pad's events in this format.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "teleop.hpp"

namespace springbok::teleop {

struct InputEvent {
  int type = 0;
  int code = 0;
  int value = 0;
};

class EventSource {
 public:
  enum class Next { event, none, gone };
  virtual ~EventSource() = default;
  // Waits up to timeout_s for the next event: `event` (in `out`), `none` (the wait ended),
  // `gone` (the device is unplugged, or the stream ended).
  virtual Next next(double timeout_s, InputEvent& out) = 0;
  // The ranges of the axes the device (or the stream's header) reports.
  virtual std::vector<std::pair<int, AxisRange>> axes() const = 0;
  virtual std::string name() const = 0;
};

// Opens an evdev device (e.g. /dev/input/event3); nullptr and `error` when it cannot.
std::unique_ptr<EventSource> open_device(const std::string& path, std::string& error);
// Reads a recorded stream; nullptr and `error` (naming the line) when it is not one.
std::unique_ptr<EventSource> open_recording(const std::string& path, std::string& error);

// One line of the stream format for an event at t_s ("0.120 EV_KEY BTN_TL 1").
std::string format_event(double t_s, const InputEvent& e);
// The stream's line for an unplug at t_s ("2.500 unplug").
std::string format_unplug(double t_s);
// The name of an axis code (ABS_X), for the stream's header.
std::string axis_name(int code);

}  // namespace springbok::teleop
