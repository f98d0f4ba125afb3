// springbok-teleop's mapping from a gamepad to operator commands (operator.hpp's text
// protocol), without I/O: input events in (Linux evdev codes, a monotonic time in seconds),
// command lines out.
//
//   sticks      walk v_x v_y yaw_rate, sent every period while the dead-man is held:
//               left stick up = +v_x (forward), left = +v_y, right stick left = +yaw rate,
//               each scaled to the trot's velocity limits (gait::kTrotFields) times
//               `speed_fraction`, with a dead zone around the centre
//   dead-man    held: walking; released, the pad unplugged, or no event for
//               `event_timeout_s`: "walk 0 0 0" and "gait stand", once, and no walking
//               until it is pressed again (after a timeout or an unplug a fresh press)
//   buttons     on press: start, stop, mode control, mode stand, gait trot, gait stand
//
// The default layout is an XInput pad's as Linux names it (Xbox, Logitech F310 in X mode):
// LB (BTN_TL) the dead-man, START start, BACK (BTN_SELECT) stop, A (BTN_SOUTH) mode control,
// B (BTN_EAST) mode stand, Y (BTN_WEST on xpad) gait trot, X (BTN_NORTH on xpad) gait stand.
#pragma once

#include <linux/input-event-codes.h>

#include <array>
#include <string>
#include <vector>

namespace springbok::teleop {

struct AxisRange {
  int min = -32768;
  int max = 32767;
};

struct TeleopConfig {
  double period_s = 0.05;            // walk commands at 20 Hz while the dead-man is held
  double event_timeout_s = 0.5;      // no event for this long: as if the dead-man were released
  double dead_zone = 0.1;            // of the stick's half range, around its centre
  double speed_fraction = 1.0;       // of the trot's velocity limits, (0, 1]
  int axis_forward = ABS_Y;          // up is negative on Linux pads
  int axis_sideways = ABS_X;         // left is negative
  int axis_yaw = ABS_RX;             // left is negative
  int button_dead_man = BTN_TL;
};

// What a button press sends.
struct ButtonCommand {
  int code;
  const char* line;
};
inline constexpr std::array<ButtonCommand, 6> kButtons = {{
    {BTN_START, "start"},
    {BTN_SELECT, "stop"},
    {BTN_SOUTH, "mode control"},
    {BTN_EAST, "mode stand"},
    {BTN_WEST, "gait trot"},
    {BTN_NORTH, "gait stand"},
}};

class Teleop {
 public:
  explicit Teleop(const TeleopConfig& config);

  // The device's range for an axis (from its absinfo); axes default to +-32767.
  void set_axis_range(int code, AxisRange range);
  // One input event (type, code, value as evdev's) at t_s.
  void event(double t_s, int type, int code, int value);
  // The device is gone (unplugged, or its stream ended).
  void unplugged(double t_s);
  // The command lines due at t_s, appended to `out` in order; call at least every period.
  void poll(double t_s, std::vector<std::string>& out);

  // The velocity the sticks ask for now [v_x, v_y, yaw rate] (m/s, m/s, rad/s).
  std::array<double, 3> velocity() const;
  bool walking() const noexcept { return walking_; }
  bool connected() const noexcept { return connected_; }

 private:
  double axis(int code) const;
  void stop(std::vector<std::string>& out);

  TeleopConfig config_;
  std::array<double, 3> max_{};   // the velocity limits, times speed_fraction
  std::vector<std::pair<int, AxisRange>> ranges_;
  std::vector<std::pair<int, int>> values_;  // the axes' last values
  std::vector<std::string> queued_;          // button commands since the last poll
  bool dead_man_ = false;                    // held, as the device reports it
  bool armed_ = false;                       // walking allowed: pressed since the last stop
  bool walking_ = false;                     // walk commands are being sent
  bool connected_ = true;
  double last_event_s_ = 0.0;
  double next_walk_s_ = 0.0;
};

}  // namespace springbok::teleop
