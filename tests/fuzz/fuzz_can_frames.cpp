// libFuzzer: arbitrary frames into every decoder (host side) and into the emulated
// drives (drive side: NMT, SDO object access, PDO mapping, state machine). Each
// 12-byte chunk of the input is one frame: id (2 bytes), len, flags, 8 data bytes.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "springbok/can/cia402.hpp"
#include "springbok/can/config.hpp"
#include "springbok/can/mit.hpp"
#include "springbok/can/socketcan.hpp"
#include "springbok/drive_emulator/drives.hpp"

using namespace springbok;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const can::DriveConfig mit_cfg = can::default_drive(2, can::Protocol::mit);
  const can::DriveConfig cia_cfg = can::default_drive(2, can::Protocol::cia402);
  emu::MitDrive mit_drive(mit_cfg, false, emu::make_joint_model(2, -1.4), {}, 10);
  emu::Cia402Drive cia_drive(cia_cfg, emu::make_joint_model(2, -1.4), {}, 0);
  std::vector<can::Frame> out;
  cia_drive.boot(0, out);
  std::int64_t now_ns = 0;
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
  return 0;
}
