// The hardware abstraction: a lifecycle (configure -> activate -> read/write
// per tick -> deactivate) and one virtual call per exchange per tick. Backends
// are `final` classes chosen at link time: springbok (SocketCAN drives) and
// springbok-sim (Bullet). The controller never knows which one runs it.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "springbok/hal/types.hpp"

namespace springbok::hal {

enum class IoStatus : std::uint8_t {
  ok = 0,
  partial = 1,   // some joints missed their reply this tick (see DriveStatus)
  timeout = 2,   // no fresh data at all
  error = 3,     // the backend failed (bus-off, socket error, simulator error)
};

// Result of a start-up / shut-down step; start-up code may allocate.
struct LifecycleResult {
  bool ok = true;
  std::string message;  // what went wrong, naming the part
  static LifecycleResult success() { return {}; }
  static LifecycleResult failure(std::string why) { return {false, std::move(why)}; }
};

class Hardware {
 public:
  virtual ~Hardware() = default;

  virtual std::string_view name() const noexcept = 0;

  // Start-up, not real-time: open devices, check the layout, boot drives.
  virtual LifecycleResult configure() = 0;
  // Power stages on; after this, read/write run every tick.
  virtual LifecycleResult activate() = 0;

  // rt: no alloc, no block (bounded waits only). Fills every field it can.
  virtual IoStatus read(Measurements& out) noexcept = 0;
  // rt: no alloc, no block.
  virtual IoStatus write(const JointCommands& cmd) noexcept = 0;

  // Damping then power off; safe to call more than once.
  virtual void deactivate() noexcept = 0;

  // What the backend counted (errors, rejected frames), one line per part, for the
  // operator at shut-down; "" when it keeps nothing. Not real-time.
  virtual std::string diagnostics_report() const { return {}; }
};

}  // namespace springbok::hal
