// One tick of the firmware, the executive's body:
//   HAL read -> supervisor checks (observe) -> operator mailbox (to the supervisor or the
//   controller) -> mode controller (compute; its state published) -> supervisor (finish:
//   damping, clamping) -> HAL write -> the tick's record: log events, status, the flight
//   recorder's record (every tick) and every N ticks a telemetry record into its ring
// Fixed-size structs passed by reference; the controller is a template
// parameter (no virtual call, no std::function); one virtual call per HAL
// exchange. Mode and fault changes, verdicts, HAL errors and the warnings (sensors lost,
// buses degraded, drives' supply low) go to the log ring.
#pragma once

#include <algorithm>
#include <limits>

#include "springbok/app/flight_recorder.hpp"
#include "springbok/app/mode_controller.hpp"
#include "springbok/app/operator.hpp"
#include "springbok/app/telemetry.hpp"
#include "springbok/hal/hardware.hpp"
#include "springbok/rt/executive.hpp"
#include "springbok/safety/supervisor.hpp"

namespace springbok::app {

template <class Controller>
class ControlLoop {
 public:
  ControlLoop(hal::Hardware& hardware, Controller& controller, safety::Supervisor& supervisor,
              OperatorMailbox& mailbox, LoopStatus& status, rt::LogRing* log) noexcept
      : hal_(hardware), controller_(controller), supervisor_(supervisor), mailbox_(mailbox), status_(status),
        log_(log) {}

  // read -> observe -> compute -> finish -> write, then the tick's record.
  // rt: no alloc, no block
  void tick(const rt::TickInfo& info) noexcept {
    const Before before{supervisor_.mode(), supervisor_.faults()};
    const hal::IoStatus io = hal_.read(meas_);
    supervisor_.observe(meas_, io, info.overrun_streak, info.overruns_in_window);
    OperatorRequest request;
    if (mailbox_.take(request)) take(info, request);

    ControlInput input;
    input.mode = supervisor_.mode();
    input.ticks_in_mode = supervisor_.ticks_in_mode();
    input.dt_s = static_cast<double>(info.elapsed_ns) * 1e-9;
    input.meas = &meas_;
    computed_mode_ = input.mode;
    const safety::ControllerReport report = controller_.compute(input, cmd_);
    controller_.publish(status_.controller);
    cmd_.sequence = info.index;
    supervisor_.finish(meas_, report, cmd_);
    const hal::IoStatus wio = hal_.write(cmd_);
    record(info, before, io, wio);
  }

  // Live telemetry: a record every `every_ticks` ticks into `ring` (nullptr: none). Start-up.
  void set_telemetry(TelemetryRing* ring, std::uint32_t every_ticks) noexcept {
    telemetry_ = ring;
    telemetry_every_ = every_ticks < 1 ? 1 : every_ticks;
  }
  // The flight recorder: the record of every tick, and a file asked for when a fault latches
  // (nullptr: none). Start-up.
  void set_recorder(FlightRecorder* recorder) noexcept { recorder_ = recorder; }

  const hal::Measurements& measurements() const noexcept { return meas_; }
  const hal::JointCommands& commands() const noexcept { return cmd_; }
  // The mode the last tick's controller computed in (the operator's command of that tick taken,
  // before the supervisor's finish).
  safety::Mode computed_mode() const noexcept { return computed_mode_; }

 private:
  // An operator's request: the supervisor's command or the controller's request,
  // and the verdict back. rt: no alloc, no block
  void take(const rt::TickInfo& info, const OperatorRequest& request) noexcept {
    OperatorReply reply;
    reply.id = request.id;
    if (request.for_controller) {
      reply.refusal = controller_.request(request.request, supervisor_.mode());
      reply.accepted = reply.refusal == nullptr;
      log(info, reply.accepted ? rt::LogEvent::controller_request : rt::LogEvent::controller_request_refused,
          static_cast<std::int64_t>(request.request.kind), static_cast<std::int64_t>(request.request.gait.kind),
          request.request.kind == ControllerRequest::Kind::tune ? request.request.tune.ramp_s
                                                                : request.request.gait.trot.step_frequency_hz);
    } else {
      reply.verdict = supervisor_.request(request.command);
      reply.accepted = reply.verdict == safety::Verdict::accepted;
      reply.refusal = reply.accepted ? nullptr : safety::to_string(reply.verdict);
      log(info, reply.accepted ? rt::LogEvent::command_accepted : rt::LogEvent::command_rejected,
          static_cast<std::int64_t>(request.command), static_cast<std::int64_t>(reply.verdict));
    }
    reply.mode = supervisor_.mode();
    reply.faults = supervisor_.faults();
    mailbox_.replies.push(reply);
  }

  // The tick's record: the loop's part and the controller's. rt: no alloc, no block
  void fill_record(const rt::TickInfo& info) noexcept {
    TelemetryRecord& r = telemetry_record_;
    r = TelemetryRecord{};
    r.timestamp_s = static_cast<double>(info.scheduled_ns) * 1e-9;
    r.tick = info.index;
    r.mode = static_cast<std::uint8_t>(supervisor_.mode());
    r.faults = supervisor_.faults();
    r.compute_us = static_cast<double>(info.previous_compute_ns) * 1e-3;
    r.wake_latency_us = static_cast<double>(info.wake_latency_ns) * 1e-3;
    for (int j = 0; j < kNj; ++j) {
      const auto i = static_cast<std::size_t>(j);
      r.q_rad[i] = meas_.q_rad[j];
      r.qd_rad_s[i] = meas_.qd_rad_s[j];
      r.tau_nm[i] = meas_.tau_nm[j];
      r.bus_voltage_v[i] = meas_.drives[i].bus_voltage_v;
    }
    if constexpr (requires(Controller& c, TelemetryRecord& t) { c.telemetry(t); }) controller_.telemetry(r);
  }

  struct Before {
    safety::Mode mode;
    safety::FaultMask faults;
  };

  // What the tick changed, into the log ring (mode and fault changes, HAL errors, the
  // warnings), the loop's status and, every N ticks, a telemetry record. rt: no alloc, no block
  void record(const rt::TickInfo& info, const Before& before, hal::IoStatus io, hal::IoStatus wio) noexcept {
    if (io != hal::IoStatus::ok || wio != hal::IoStatus::ok) {
      status_.hal_errors.fetch_add(1, std::memory_order_relaxed);
    }
    if (io != last_io_) {
      log(info, rt::LogEvent::hal_io, static_cast<std::int64_t>(io), supervisor_.stale_ticks());
      last_io_ = io;
    }
    if (supervisor_.faults() != before.faults) {
      log(info, rt::LogEvent::fault_latched, supervisor_.faults() & ~before.faults, supervisor_.faults());
      if ((supervisor_.faults() & ~before.faults & safety::fault::kJointLimit) != 0) {
        log(info, rt::LogEvent::joint_limit, supervisor_.limit_joint(), static_cast<std::int64_t>(before.mode),
            supervisor_.limit_joint_position_rad());
      }
    }
    if (supervisor_.sensors_lost() != sensors_lost_) {  // a warning outside the control mode, a fault in it
      sensors_lost_ = supervisor_.sensors_lost();
      log(info, rt::LogEvent::sensors_lost, sensors_lost_, static_cast<std::int64_t>(supervisor_.mode()));
    }
    if (supervisor_.degraded_buses() != degraded_buses_) {  // a warning: the robot keeps going
      log(info, rt::LogEvent::buses_degraded, supervisor_.degraded_buses(), degraded_buses_);
      degraded_buses_ = supervisor_.degraded_buses();
    }
    {  // drives reporting a supply below the backend's warning: a warning (below its fault: a drive fault)
      std::uint32_t low = 0;
      double lowest_v = std::numeric_limits<double>::infinity();
      for (int j = 0; j < kNj; ++j) {
        const hal::DriveStatus& d = meas_.drives[static_cast<std::size_t>(j)];
        if (d.bus_voltage_low) low |= std::uint32_t{1} << j;
        if (d.bus_voltage_v > 0.0) lowest_v = std::min(lowest_v, d.bus_voltage_v);
      }
      if (low != low_voltage_drives_) {
        log(info, rt::LogEvent::bus_voltage_low, low, low_voltage_drives_, lowest_v);
        low_voltage_drives_ = low;
      }
    }
    if (supervisor_.mode() != before.mode) {
      log(info, rt::LogEvent::mode_change, static_cast<std::int64_t>(before.mode),
          static_cast<std::int64_t>(supervisor_.mode()));
    }
    status_.mode.store(static_cast<std::uint8_t>(supervisor_.mode()), std::memory_order_relaxed);
    status_.faults.store(supervisor_.faults(), std::memory_order_relaxed);
    status_.stale_ticks.store(supervisor_.stale_ticks(), std::memory_order_relaxed);
    status_.limit_joint_position_rad.store(supervisor_.limit_joint_position_rad(), std::memory_order_relaxed);
    status_.limit_joint.store(supervisor_.limit_joint(), std::memory_order_release);
    const bool telemetry_tick = telemetry_ != nullptr && info.index % telemetry_every_ == 0;
    if (recorder_ != nullptr || telemetry_tick) fill_record(info);
    if (telemetry_tick) (void)telemetry_->push(telemetry_record_);  // a full ring drops it and counts
    if (recorder_ != nullptr) {
      recorder_->record(telemetry_record_);
      if ((supervisor_.faults() & ~before.faults) != 0) recorder_->request(DumpReason::fault);
    }
  }

  void log(const rt::TickInfo& info, rt::LogEvent event, std::int64_t a, std::int64_t b, double x = 0.0) noexcept {
    if (log_ != nullptr) log_->push(rt::LogRecord{info.index, info.wake_ns, event, a, b, x});
  }

  hal::Hardware& hal_;
  Controller& controller_;
  safety::Supervisor& supervisor_;
  OperatorMailbox& mailbox_;
  LoopStatus& status_;
  rt::LogRing* log_;
  hal::Measurements meas_;
  hal::JointCommands cmd_;
  safety::Mode computed_mode_ = safety::Mode::idle;
  hal::IoStatus last_io_ = hal::IoStatus::ok;
  safety::FaultMask sensors_lost_ = 0;
  std::uint32_t degraded_buses_ = 0;
  std::uint32_t low_voltage_drives_ = 0;  // bit j: joint j's drive reports its supply below the warning
  TelemetryRing* telemetry_ = nullptr;
  FlightRecorder* recorder_ = nullptr;
  std::uint32_t telemetry_every_ = 1;
  TelemetryRecord telemetry_record_;
};

}  // namespace springbok::app
