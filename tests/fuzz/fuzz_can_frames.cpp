// libFuzzer: arbitrary frames into every decoder (host side) and into the emulated
// drives (drive side: NMT, SDO object access, PDO mapping, state machine), and into the
// sensor assemblers (CAN.md 6: IMU, wrist F/T). Each 12-byte chunk of the input is one
// frame: id (2 bytes), len, flags, 8 data bytes. Flags bit 2 maps the frame onto a sensor
// id (so the assemblers see mostly their own frames), bits 4..5 advance the tick.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "springbok/can/cia402.hpp"
#include "springbok/can/config.hpp"
#include "springbok/can/mit.hpp"
#include "springbok/can/sensors.hpp"
#include "springbok/can/socketcan.hpp"
#include "springbok/drive_emulator/drives.hpp"
#include "springbok/drive_emulator/sensors.hpp"

using namespace springbok;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const can::DriveConfig mit_cfg = can::default_drive(2, can::Protocol::mit);
  const can::DriveConfig cia_cfg = can::default_drive(2, can::Protocol::cia402);
  emu::MitDrive mit_drive(mit_cfg, false, emu::make_joint_model(2, -1.4), {}, 10);
  emu::Cia402Drive cia_drive(cia_cfg, emu::make_joint_model(2, -1.4), {}, 0);
  std::vector<can::Frame> out;
  cia_drive.boot(0, out);
  std::int64_t now_ns = 0;
  can::SensorsConfig sensors_cfg;
  sensors_cfg.imu.enabled = sensors_cfg.wrist_ft.enabled = true;
  sensors_cfg.imu.stale_ticks = 1 + (size % 5);
  can::ImuAssembler imu;
  can::FtAssembler ft;
  imu.configure(sensors_cfg.imu, 0);
  ft.configure(sensors_cfg.wrist_ft, 0);
  std::uint64_t tick = 0;
  for (std::size_t at = 0; at + 12 <= size; at += 12) {
    const std::uint8_t* c = data + at;
    can::Frame f;
    f.id = (std::uint32_t{c[0]} | (std::uint32_t{c[1]} << 8)) & 0x7FF;
    f.len = static_cast<std::uint8_t>(c[2] % 9);  // classic frames: 0..8 bytes
    f.error = (c[3] & 1) != 0;
    f.fd = (c[3] & 2) != 0;
    for (int i = 0; i < 8; ++i) f.data[i] = c[4 + i];
    const std::uint8_t node = static_cast<std::uint8_t>(c[3] >> 1);

    can::mit::Reply reply;
    can::mit::Command cmd;
    (void)can::mit::decode_reply(f, mit_cfg.mit_ranges, reply);
    (void)can::mit::decode_command(f, mit_cfg.mit_ranges, cmd);
    (void)can::mit::classify(f);
    can::cia402::NmtCommand cs{};
    can::cia402::NmtState st{};
    can::cia402::Emcy emcy;
    can::cia402::SdoRequest req;
    can::cia402::SdoResponse res;
    can::cia402::Rpdo1 rpdo;
    can::cia402::Feedback fb;
    std::uint8_t nmt_node = 0;
    (void)can::cia402::decode_nmt(f, cs, nmt_node);
    (void)can::cia402::decode_heartbeat(f, node, st);
    (void)can::cia402::decode_emcy(f, node, emcy);
    (void)can::cia402::decode_sdo_request(f, node, req);
    (void)can::cia402::decode_sdo_response(f, node, res);
    (void)can::cia402::decode_rpdo1(f, node, rpdo);
    (void)can::cia402::decode_tpdo1(f, node, can::cia402::Mapping::compact, fb);
    (void)can::cia402::decode_tpdo1(f, node, can::cia402::Mapping::two_tpdo, fb);
    (void)can::cia402::decode_tpdo2(f, node, fb);
    (void)can::cia402::decode_statusword(static_cast<std::uint16_t>(f.data[0] | (f.data[1] << 8)));
    (void)can::classify_error_frame(f);

    // ---- sensors: frames into the assemblers; what they accept must be sane ----
    if ((c[3] & 4) != 0) {
      f.id = (c[0] & 1) != 0 ? 0x6A0u + c[1] % 3u : 0x6B0u + c[1] % 2u;
      f.len = (c[2] & 0x80) != 0 ? f.len : 8;  // mostly well-formed
    }
    tick += (c[3] >> 4) & 3u;
    can::SensorFrameFields ff;
    Eigen::Quaterniond q;
    if (can::decode_sensor_frame(f, ff) == can::FrameStatus::ok) (void)can::decode_quaternion(ff.v, 1.0 / 32768.0, q);
    if (imu.frame_index(f.id) >= 0) (void)imu.push(f, tick);
    if (ft.frame_index(f.id) >= 0) (void)ft.push(f, tick);
    imu.update(tick);
    ft.update(tick);
    if (imu.usable()) {
      const can::ImuReading r = imu.reading();
      const double n = r.orientation.norm();
      if (!(n > 0.9999 && n < 1.0005) || r.orientation.w() < 0.0) __builtin_trap();  // |q_xyz|^2 <= 1 + 2^-10
      if (!r.angular_rate_rad_s.allFinite() || r.angular_rate_rad_s.cwiseAbs().maxCoeff() > 32.0) __builtin_trap();
      if (!r.linear_accel_m_s2.allFinite() || r.linear_accel_m_s2.cwiseAbs().maxCoeff() > 64.0) __builtin_trap();
      if ((imu.diagnostics().last_status & (can::sensor_status::reserved | can::sensor_status::valid)) !=
          can::sensor_status::valid) {
        __builtin_trap();  // an accepted sample is valid with clean reserved bits
      }
    }
    if (ft.usable() && (ft.reading().force_n.cwiseAbs().maxCoeff() > 512.0 || ft.reading().torque_nm.cwiseAbs().maxCoeff() > 32.768)) {
      __builtin_trap();
    }
    if (imu.diagnostics().samples_accepted * 3 > imu.diagnostics().frames) __builtin_trap();

    now_ns += 1000000;
    mit_drive.on_frame(f, now_ns, out);
    cia_drive.on_frame(f, now_ns, out);
    mit_drive.on_time(now_ns, out);
    cia_drive.on_time(now_ns, out);
    // Whatever the drives answer must decode on the host side without trouble.
    for (const can::Frame& o : out) {
      (void)can::mit::decode_reply(o, mit_cfg.mit_ranges, reply);
      (void)can::cia402::decode_sdo_response(o, 3, res);
      (void)can::cia402::decode_tpdo1(o, 3, can::cia402::Mapping::compact, fb);
    }
    out.clear();
  }
  // The emulator's sensor side with values from the input: what it encodes decodes back
  // within half an LSB (or saturates with the clipping bit).
  if (size >= 24) {
    hal::Imu in_imu;
    hal::Wrench in_wrist;
    in_imu.valid = in_wrist.valid = true;
    const auto val = [&](std::size_t i, double scale) {
      return static_cast<double>(static_cast<std::int16_t>(data[i] | (data[i + 1] << 8))) * scale;
    };
    in_imu.orientation = Eigen::Quaterniond(val(0, 1.0), val(2, 1.0), val(4, 1.0), val(6, 1.0));
    if (in_imu.orientation.norm() == 0.0) in_imu.orientation = Eigen::Quaterniond::Identity();
    in_imu.angular_rate_rad_s = Eigen::Vector3d(val(8, 1e-3), val(10, 1e-3), val(12, 1e-3));
    in_imu.linear_accel_m_s2 = Eigen::Vector3d(val(14, 3e-3), val(16, 3e-3), val(18, 3e-3));
    in_wrist.force_n = Eigen::Vector3d(val(20, 0.02), val(22, 0.02), val(0, 0.02));
    in_wrist.torque_nm = Eigen::Vector3d(val(2, 1e-3), val(4, 1e-3), val(6, 1e-3));
    emu::SensorEmulator emu(sensors_cfg, {});
    std::vector<can::Frame> imu_out, ft_out;
    emu.publish(in_imu, in_wrist, imu_out, ft_out);
    can::ImuAssembler imu2;
    can::FtAssembler ft2;
    imu2.configure(sensors_cfg.imu, 0);
    ft2.configure(sensors_cfg.wrist_ft, 0);
    for (const can::Frame& f : imu_out) (void)imu2.push(f, 1);
    for (const can::Frame& f : ft_out) (void)ft2.push(f, 1);
    imu2.update(1);
    ft2.update(1);
    if (!imu2.usable() || !ft2.usable()) __builtin_trap();
    const bool imu_clipped = (imu2.diagnostics().last_status & can::sensor_status::clipping) != 0;
    const double rate_err = (imu2.reading().angular_rate_rad_s - in_imu.angular_rate_rad_s).cwiseAbs().maxCoeff();
    if (!imu_clipped && rate_err > 0.5 / 1024.0 + 1e-12) __builtin_trap();
    // Half a count, or one at the rail: a component of 1 (more than 32767.5 counts) goes out
    // as 32767, which is no clipping (a unit quaternion never leaves [-1, 1]).
    const Eigen::Vector3d q_true = (in_imu.orientation.w() < 0 ? -1.0 : 1.0) * in_imu.orientation.normalized().vec();
    for (int i = 0; i < 3; ++i) {
      const double bound = (std::abs(q_true[i]) * 32768.0 > 32767.5 ? 1.0 : 0.5) / 32768.0 + 1e-12;
      if (!imu_clipped && std::abs(imu2.reading().orientation.vec()[i] - q_true[i]) > bound) __builtin_trap();
    }
    const bool ft_clipped = (ft2.diagnostics().last_status & can::sensor_status::clipping) != 0;
    if (!ft_clipped && (ft2.reading().force_n - in_wrist.force_n).cwiseAbs().maxCoeff() > 0.5 / 64.0 + 1e-12) __builtin_trap();
  }
  return 0;
}
