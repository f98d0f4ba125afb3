// The CAN config: built-in layouts validate; the YAML loader reads every field
// and rejects bad input with an error naming the field.
#include <gtest/gtest.h>

#include <limits>
#include <string>

#include "springbok/can/config_yaml.hpp"
#include "springbok/model/model.hpp"

namespace springbok::can {
namespace {

// CAN.md 4.2 step 3's expected pose, which a config with MIT drives must give: the stance.
constexpr const char* kStartPose =
    "start_pose: {q_rad: [0, 0.7, -1.4, 0, 0.7, -1.4, 0, -0.7, 1.4, 0, -0.7, 1.4, 0, 0, 0, 0, 0, 0, 0]}";
// A one-line `can:` map with `keys` and the start pose.
std::string can_map(const std::string& keys) { return "can: {" + keys + ", " + kStartPose + "}"; }

// `c` with the stance as its start pose (the built-in layouts carry none: it is the robot's, not the buses').
CanConfig with_stance_start_pose(CanConfig c) {
  c.start_pose.given = true;
  const double front[3] = {0.0, 0.7, -1.4};
  for (int j = 0; j < 12; ++j) c.start_pose.q_rad[static_cast<std::size_t>(j)] = (j < 6 ? 1.0 : -1.0) * front[j % 3];
  return c;
}

TEST(CanConfig, BuiltInLayoutsAreValid) {
  EXPECT_EQ(validate(with_stance_start_pose(classic7_layout(Protocol::mit))), "");
  EXPECT_EQ(validate(classic7_layout(Protocol::cia402)), "");  // no MIT drive: no start pose needed
  EXPECT_EQ(validate(with_stance_start_pose(fd5_layout())), "");
}

TEST(CanConfig, LayoutShortcutFromYaml) {
  const ConfigResult r = load_can_config_text(R"(
can:
  layout: classic7
  protocol: cia402
  interface_prefix: vcan
  timing: {missed_replies_lost: 5, rx_deadline_us: 20000}
)");
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_EQ(r.config.buses.size(), 7u);
  EXPECT_EQ(r.config.buses[6].interface, "vcan6");
  EXPECT_EQ(r.config.buses[6].drives[1].drive_id, 19);
  EXPECT_EQ(r.config.buses[6].drives[1].protocol, Protocol::cia402);
  EXPECT_EQ(r.config.timing.missed_replies_lost, 5u);
  EXPECT_EQ(r.config.timing.rx_deadline_us, 20000u);
  EXPECT_EQ(r.config.timing.sdo_timeout_ms, 100u);  // default kept
}

std::string full_config(const std::string& lf_drive0_extra) {
  std::string s = "can:\n  max_bus_load: 0.8\n  buses:\n";
  const char* names[] = {"lf", "rf", "lh", "rh", "arm0", "arm1", "arm2"};
  const int first[] = {0, 3, 6, 9, 12, 15, 17};
  const int count[] = {3, 3, 3, 3, 3, 2, 2};
  for (int b = 0; b < 7; ++b) {
    s += "    - name: " + std::string(names[b]) + "\n      interface: vcan" + std::to_string(b) + "\n";
    s += "      protocol: mit\n      drives:\n";
    for (int j = first[b]; j < first[b] + count[b]; ++j) {
      s += "        - joint: " + std::to_string(j) + "\n          id: " + std::to_string(j + 1) + "\n";
      if (j == 0) s += lf_drive0_extra;
    }
  }
  return s + "  " + kStartPose + "\n";
}

TEST(CanConfig, ExplicitBusesWithEveryDriveField) {
  const ConfigResult r = load_can_config_text(full_config(
      "          reply_id: 0x181\n          vendor_reply: true\n"
      "          mit_ranges: {p: [-12.5, 12.5], v: [-45, 45], kp: [0, 500], kd: [0, 5], t: [-15, 15]}\n"));
  ASSERT_TRUE(r.ok) << r.error;
  const DriveConfig& d = r.config.buses[0].drives[0];
  EXPECT_EQ(d.mit_reply_id, 0x181);
  EXPECT_TRUE(d.mit_vendor_reply);
  EXPECT_DOUBLE_EQ(d.mit_ranges.v_max_rad_s, 45.0);
  EXPECT_DOUBLE_EQ(d.mit_ranges.t_min_nm, -15.0);
  // Defaults of the other drives: reply id 0x100 + id, torque range = the joint's peak limit.
  EXPECT_EQ(r.config.buses[0].drives[1].mit_reply_id, 0x102);
  EXPECT_DOUBLE_EQ(r.config.buses[0].drives[1].mit_ranges.t_max_nm, 162.0);  // lf_hfe: F b
  EXPECT_DOUBLE_EQ(r.config.buses[6].drives[1].mit_ranges.t_max_nm, 9.0);
}

// CAN.md 1.4: the reply id is the drive's CAN_MASTER setting (default 0 on every drive) and
// the host matches replies on byte 0, so drives may share one, 0 included; an id not used by
// the bus's drives otherwise is fine even below 128.
TEST(CanConfig, MitDrivesMayShareAReplyIdTheFactoryDefaultZeroIncluded) {
  std::string shared = full_config("          reply_id: 0x102\n");  // drive 2's default reply id
  ConfigResult r = load_can_config_text(shared);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.config.buses[0].drives[0].mit_reply_id, r.config.buses[0].drives[1].mit_reply_id);
  std::string zero = full_config("");
  for (std::size_t at = zero.find("          id: "); at != std::string::npos; at = zero.find("          id: ", at + 1)) {
    const std::size_t eol = zero.find('\n', at);
    zero.insert(eol + 1, "          reply_id: 0\n");
  }
  r = load_can_config_text(zero);
  ASSERT_TRUE(r.ok) << r.error;
  for (const BusConfig& b : r.config.buses) {
    for (const DriveConfig& d : b.drives) EXPECT_EQ(d.mit_reply_id, 0u) << int{d.drive_id};
  }
  // 100 is no drive of bus lf (drives 1..3): allowed.
  r = load_can_config_text(full_config("          reply_id: 100\n"));
  EXPECT_TRUE(r.ok) << r.error;
}

// The drive's 0x6076 scales its torques (CAN.md 2.4): the config's rated torque is optional
// (0 = not given) and so is the cap on 0x6072 (0 = the joint's torque limit).
TEST(CanConfig, Cia402RatedTorqueAndMaxTorqueAreOptional) {
  const ConfigResult absent = load_can_config_text(full_config("          protocol: cia402\n"));
  ASSERT_TRUE(absent.ok) << absent.error;
  EXPECT_EQ(absent.config.buses[0].drives[0].rated_torque_nm, 0.0);
  EXPECT_EQ(absent.config.buses[0].drives[0].max_torque_permille, 0);
  EXPECT_EQ(default_drive(12, Protocol::cia402).rated_torque_nm, 0.0);
  const ConfigResult given = load_can_config_text(
      full_config("          protocol: cia402\n          rated_torque_nm: 150\n          max_torque_permille: 800\n"));
  ASSERT_TRUE(given.ok) << given.error;
  EXPECT_EQ(given.config.buses[0].drives[0].rated_torque_nm, 150.0);
  EXPECT_EQ(given.config.buses[0].drives[0].max_torque_permille, 800);
}

TEST(CanConfig, JointByName) {
  std::string s = full_config("");
  const auto pos = s.find("joint: 0\n");
  s.replace(pos, 9, "joint: lf_haa_joint\n");
  const ConfigResult r = load_can_config_text(s);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.config.buses[0].drives[0].joint, 0);
}

struct BadCase {
  const char* extra;
  const char* field;
};

TEST(CanConfig, ErrorsNameTheField) {
  const BadCase cases[] = {
      {"          reply_id: 0x800\n", "can.buses[0].drives[0].reply_id"},
      {"          reply_id: 2\n", "can.buses[0].drives[0].reply_id: 2 is the command id of drive 2"},
      {"          vendor_reply: maybe\n", "can.buses[0].drives[0].vendor_reply"},
      {"          mit_ranges: {t: [15, -15]}\n", "can.buses[0].drives[0].mit_ranges.t"},
      {"          mit_ranges: {t: [.nan, 15]}\n", "can.buses[0].drives[0].mit_ranges.t[0]"},
      {"          mit_ranges: {q: [0, 1]}\n", "can.buses[0].drives[0].mit_ranges.q"},
      {"          protocol: canopen\n", "can.buses[0].drives[0].protocol"},
      {"          colour: red\n", "can.buses[0].drives[0].colour: unknown key"},
      {"          mapping: three\n", "can.buses[0].drives[0].mapping"},
      {"          protocol: cia402\n          rated_torque_nm: -1\n", "can.buses[0].drives[0].rated_torque_nm"},
      {"          protocol: cia402\n          rated_torque_nm: .inf\n", "can.buses[0].drives[0].rated_torque_nm"},
      {"          protocol: cia402\n          max_torque_permille: 40000\n", "can.buses[0].drives[0].max_torque_permille"},
      {"          protocol: cia402\n          gear_ratio: 0\n", "can.buses[0].drives[0].gear_ratio"},
  };
  for (const BadCase& c : cases) {
    const ConfigResult r = load_can_config_text(full_config(c.extra));
    EXPECT_FALSE(r.ok) << c.extra;
    EXPECT_NE(r.error.find(c.field), std::string::npos) << "expected '" << c.field << "' in: " << r.error;
  }
}

TEST(CanConfig, StructuralErrors) {
  std::string dup = full_config("");
  dup.replace(dup.find("id: 2\n"), 6, "id: 1\n");
  EXPECT_NE(load_can_config_text(dup).error.find("can.buses[0].drives[1].id: 1 used twice"), std::string::npos);

  std::string missing = full_config("");
  missing.replace(missing.find("joint: 18\n"), 10, "joint: 17\n");
  const ConfigResult r = load_can_config_text(missing);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("can.buses[6].drives[1].joint"), std::string::npos) << r.error;

  EXPECT_NE(load_can_config_text("can: {layout: classic9}").error.find("can.layout"), std::string::npos);
  EXPECT_NE(load_can_config_text("can: {}").error.find("can: needs `layout` or `buses`"), std::string::npos);
  EXPECT_NE(load_can_config_text("robot: 1").error.find("can: missing"), std::string::npos);
  EXPECT_NE(load_can_config_text("can: [1, 2").error.find("YAML"), std::string::npos);
  EXPECT_NE(load_can_config_text("can: {layout: classic7, timing: {tick_us: -1}}").error.find("can.timing.tick_us"),
            std::string::npos);
  EXPECT_NE(load_can_config_text(can_map("layout: classic7, max_bus_load: 1.5")).error.find("can.max_bus_load"),
            std::string::npos);
  EXPECT_NE(load_can_config_file("/nonexistent/can.yaml").error.find("cannot open"), std::string::npos);
  // Interface names as the kernel takes them (they also go to ip(8)): 1..15 printable
  // characters without '/', ':' or white space.
  for (const char* bad : {"'can;rm -rf '", "'can 1_'", "'../can'", "'vcan:'", "can_much_too_long"}) {
    const std::string text = can_map(std::string("layout: classic7, interface_prefix: ") + bad);
    EXPECT_NE(load_can_config_text(text).error.find("can.buses[0].interface: "), std::string::npos) << bad;
  }
  EXPECT_TRUE(load_can_config_text(can_map("layout: classic7, interface_prefix: vcan_a-")).ok);
  // A field applied to every drive (mit_ranges) and wrong is said once.
  const std::string ranges = load_can_config_text("can: {layout: classic7, mit_ranges: {kp: [500, 0]}}").error;
  EXPECT_EQ(ranges, "can.mit_ranges.kp: min must be below max (line 1)");
  for (const char* bad : {"-1", "500", ".nan"}) {
    const std::string text = can_map(std::string("layout: classic7, mit_velocity_observer_rad_s: ") + bad);
    EXPECT_NE(load_can_config_text(text).error.find("can.mit_velocity_observer_rad_s"), std::string::npos) << bad;
  }
  EXPECT_DOUBLE_EQ(load_can_config_text(can_map("layout: classic7, mit_velocity_observer_rad_s: 0"))
                       .config.mit_velocity_observer_rad_s,
                   0.0);
}

// The MIT drives' bus voltage thresholds (CAN.md 1.4): off by default, each in [0, 40] V, the fault
// below the warning.
TEST(CanConfig, MitBusVoltageThresholdsAreOffByDefaultAndChecked) {
  const ConfigResult none = load_can_config_text(can_map("layout: classic7"));
  ASSERT_TRUE(none.ok) << none.error;
  EXPECT_EQ(none.config.mit_bus_voltage_warning_v, 0.0);
  EXPECT_EQ(none.config.mit_bus_voltage_fault_v, 0.0);
  const ConfigResult both =
      load_can_config_text(can_map("layout: classic7, mit_bus_voltage_warning_v: 20, mit_bus_voltage_fault_v: 18.5"));
  ASSERT_TRUE(both.ok) << both.error;
  EXPECT_EQ(both.config.mit_bus_voltage_warning_v, 20.0);
  EXPECT_EQ(both.config.mit_bus_voltage_fault_v, 18.5);
  for (const char* bad : {"-1", "41", ".nan"}) {
    for (const char* field : {"mit_bus_voltage_warning_v", "mit_bus_voltage_fault_v"}) {
      const std::string error =
          load_can_config_text(can_map(std::string("layout: classic7, ") + field + ": " + bad)).error;
      const std::string why = bad[0] == '.' ? ": must be a finite number" : ": must be in [0, 40] V (0: off)";
      EXPECT_NE(error.find(std::string("can.") + field + why), std::string::npos) << field << " " << bad << ": " << error;
    }
  }
  EXPECT_NE(load_can_config_text(can_map("layout: classic7, mit_bus_voltage_warning_v: 20, mit_bus_voltage_fault_v: 20"))
                .error.find("can.mit_bus_voltage_fault_v: must be below can.mit_bus_voltage_warning_v"),
            std::string::npos);
}

TEST(CanConfig, LayoutWideMitRangesOverrideTheGainRangesOfEveryMitDrive) {
  const ConfigResult r = load_can_config_text(can_map("layout: fd5, mit_ranges: {kp: [0, 2000], kd: [0, 50]}"));
  ASSERT_TRUE(r.ok) << r.error;
  for (const BusConfig& b : r.config.buses) {
    for (const DriveConfig& d : b.drives) {
      EXPECT_DOUBLE_EQ(d.mit_ranges.kp_max, 2000.0) << d.drive_id;
      EXPECT_DOUBLE_EQ(d.mit_ranges.kd_max, 50.0) << d.drive_id;
      EXPECT_DOUBLE_EQ(d.mit_ranges.p_max_rad, 12.5) << d.drive_id;  // not listed: unchanged
      // The torque range stays the joint's peak limit (HFE / KFE: the cylinder's 162 N m).
      EXPECT_DOUBLE_EQ(d.mit_ranges.t_max_nm, torque_limit_peak_nm(d.joint));
    }
  }
  // The torque range is per joint: not accepted layout-wide; bad ranges name the field.
  EXPECT_NE(load_can_config_text("can: {layout: classic7, mit_ranges: {t: [-1, 1]}}").error.find("can.mit_ranges.t: unknown key"),
            std::string::npos);
  EXPECT_NE(load_can_config_text("can: {layout: classic7, mit_ranges: {kp: [500, 0]}}").error.find("can.mit_ranges.kp"),
            std::string::npos);
}

// CAN.md 4.2 step 3: MIT start-up checks the drives' positions against the expected pose, which
// only the config can give: required with MIT drives, read and checked at load, each error naming
// the field.
TEST(CanConfig, StartPoseIsOptionalAndCheckedWhenGiven) {
  const ConfigResult missing = load_can_config_text("can: {layout: classic7}");
  ASSERT_TRUE(missing.ok) << missing.error;  // MIT start-up then checks the joint limits alone
  EXPECT_FALSE(missing.config.start_pose.given);
  EXPECT_TRUE(load_can_config_text("can: {layout: classic7, protocol: cia402}").ok);  // CiA 402 start-up has no such step

  const ConfigResult r = load_can_config_text(can_map("layout: classic7"));
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_TRUE(r.config.start_pose.given);
  EXPECT_DOUBLE_EQ(r.config.start_pose.q_rad[1], 0.7);
  EXPECT_DOUBLE_EQ(r.config.start_pose.q_rad[8], 1.4);
  EXPECT_DOUBLE_EQ(r.config.start_pose.tolerance_rad, 0.3);  // the default
  const std::string pose = "q_rad: [0, 0.7, -1.4, 0, 0.7, -1.4, 0, -0.7, 1.4, 0, -0.7, 1.4, 0, 0, 0, 0, 0, 0, 0]";
  const auto with = [&](const std::string& start_pose) {
    return load_can_config_text("can: {layout: classic7, start_pose: {" + start_pose + "}}");
  };
  const ConfigResult tight = with(pose + ", tolerance_rad: 0.05");
  ASSERT_TRUE(tight.ok) << tight.error;
  EXPECT_DOUBLE_EQ(tight.config.start_pose.tolerance_rad, 0.05);

  struct Bad {
    std::string start_pose;
    const char* error;
  };
  const Bad cases[] = {
      {"tolerance_rad: 0.3", "can.start_pose.q_rad: missing"},
      {"q_rad: [0, 0.7, -1.4]", "can.start_pose.q_rad: must be a list of 19"},
      {"q_rad: [0, 2.0, -1.4, 0, 0.7, -1.4, 0, -0.7, 1.4, 0, -0.7, 1.4, 0, 0, 0, 0, 0, 0, 0]",
       "can.start_pose.q_rad[1]: 2.000000 rad is outside the limits of joint 'lf_hfe_joint' [-0.872665, 1.221730]"},
      {"q_rad: [0, 0.7, -1.4, 0, 0.7, -1.4, 0, -0.7, 1.4, 0, -0.7, 1.4, 0, 0, .nan, 0, 0, 0, 0]",
       "can.start_pose.q_rad[14]"},
      {pose + ", tolerance_rad: 0", "can.start_pose.tolerance_rad: must be in (0, 1.000000] rad"},
      {pose + ", tolerance_rad: -0.1", "can.start_pose.tolerance_rad: must be in (0, 1.000000] rad"},
      {pose + ", tolerance_rad: 1.5", "can.start_pose.tolerance_rad: must be in (0, 1.000000] rad"},
      {pose + ", tolerance_rad: .inf", "can.start_pose.tolerance_rad"},
      {pose + ", colour: red", "can.start_pose.colour: unknown key"},
  };
  for (const Bad& c : cases) {
    const ConfigResult bad = with(c.start_pose);
    EXPECT_FALSE(bad.ok) << c.start_pose;
    EXPECT_NE(bad.error.find(c.error), std::string::npos) << "expected '" << c.error << "' in: " << bad.error;
  }
  EXPECT_NE(load_can_config_text("can: {layout: classic7, start_pose: [0, 1]}").error.find("can.start_pose: must be a map"),
            std::string::npos);

  // The start-up check itself: within the tolerance either way; not finite is never at the pose.
  const StartPose& p = tight.config.start_pose;
  EXPECT_TRUE(at_start_pose(p, 1, 0.7));
  EXPECT_TRUE(at_start_pose(p, 1, 0.749));
  EXPECT_TRUE(at_start_pose(p, 1, 0.651));
  EXPECT_FALSE(at_start_pose(p, 1, 0.751));
  EXPECT_FALSE(at_start_pose(p, 1, 0.649));
  EXPECT_FALSE(at_start_pose(p, 1, std::numeric_limits<double>::quiet_NaN()));
}

TEST(CanConfig, ExampleFilesLoad) {
  for (const char* name : {"mit_classic7.yaml", "cia402_classic7.yaml", "mit_fd5.yaml", "stand_mit7.yaml", "wbc_mit8.yaml"}) {
    const ConfigResult r = load_can_config_file(std::string(SPRINGBOK_SOURCE_DIR) + "/tests/hil/config/" + name);
    EXPECT_TRUE(r.ok) << name << ": " << r.error;
  }
}

}  // namespace
}  // namespace springbok::can
