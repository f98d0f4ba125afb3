// Bus time and load against CAN.md section 3's tables.
#include <gtest/gtest.h>

#include "springbok/can/bus_load.hpp"

namespace springbok::can {
namespace {

TEST(BusLoad, ClassicFrameBitsWorstCase) {
  EXPECT_EQ(classic_frame_bits(0), 55);   // SYNC
  EXPECT_EQ(classic_frame_bits(2), 75);   // NMT
  EXPECT_EQ(classic_frame_bits(4), 95);   // RPDO1
  EXPECT_EQ(classic_frame_bits(6), 115);  // MIT reply, TPDO
  EXPECT_EQ(classic_frame_bits(8), 135);  // MIT command
}

TEST(BusLoad, FdFrameTimesOfTable31) {
  struct Row { int n; double us_2, us_5, us_8; };
  const Row rows[] = {{6, 80.5, 52.0, 44.9}, {8, 90.5, 56.0, 47.4}, {16, 130.5, 72.0, 57.4}, {64, 373.0, 169.0, 118.0}};
  for (const Row& r : rows) {
    EXPECT_NEAR(fd_frame_us(r.n, 1e6, 2e6), r.us_2, 0.05) << r.n;
    EXPECT_NEAR(fd_frame_us(r.n, 1e6, 5e6), r.us_5, 0.05) << r.n;
    EXPECT_NEAR(fd_frame_us(r.n, 1e6, 8e6), r.us_8, 0.05) << r.n;
  }
}

TEST(BusLoad, DefaultClassicLayoutMit) {
  const CanConfig c = classic7_layout(Protocol::mit);
  ASSERT_EQ(c.buses.size(), 7u);
  const double expected[] = {0.75, 0.75, 0.75, 0.75, 0.75, 0.50, 0.50};
  const int frames[] = {6, 6, 6, 6, 6, 4, 4};
  for (std::size_t b = 0; b < 7; ++b) {
    const BusLoad l = worst_case_load(c.buses[b], 1000.0);
    EXPECT_NEAR(l.load, expected[b], 1e-12) << c.buses[b].name;
    EXPECT_EQ(l.frames_per_tick, frames[b]) << c.buses[b].name;
  }
  EXPECT_EQ(check_bus_loads(c), "");
}

TEST(BusLoad, DefaultClassicLayoutCia402Compact) {
  const CanConfig c = classic7_layout(Protocol::cia402);
  // 3 joints: SYNC 55 + 3 * (95 + 135) = 745 us; 2 joints: 515 us.
  EXPECT_NEAR(worst_case_load(c.buses[0], 1000.0).load, 0.745, 1e-12);
  EXPECT_EQ(worst_case_load(c.buses[0], 1000.0).frames_per_tick, 7);
  EXPECT_NEAR(worst_case_load(c.buses[6], 1000.0).load, 0.515, 1e-12);
  EXPECT_EQ(check_bus_loads(c), "");
}

TEST(BusLoad, TwoTpdoMappingOnThreeJointsIsRefusedNamingTheBus) {
  CanConfig c = classic7_layout(Protocol::cia402);
  for (DriveConfig& d : c.buses[2].drives) d.mapping = cia402::Mapping::two_tpdo;
  EXPECT_NEAR(worst_case_load(c.buses[2], 1000.0).load, 1.03, 1e-12);  // 55 + 3 * 325
  const std::string err = check_bus_loads(c);
  EXPECT_NE(err.find("bus 'lh' (can2)"), std::string::npos) << err;
  EXPECT_NE(err.find("103.0 %"), std::string::npos) << err;
}

TEST(BusLoad, FourMitJointsOnAClassicBusIsRefused) {
  CanConfig c = classic7_layout(Protocol::mit);
  // Arm on two classic buses: 4 + 3 joints.
  c.buses[5].drives.insert(c.buses[5].drives.begin(), c.buses[4].drives.back());
  c.buses[4].drives.pop_back();
  c.buses[5].drives.insert(c.buses[5].drives.end(), c.buses[6].drives.begin(), c.buses[6].drives.end());
  c.buses.pop_back();
  EXPECT_NEAR(worst_case_load(c.buses[5], 1000.0).load, 1.25, 1e-12);
  EXPECT_NE(check_bus_loads(c).find("bus 'arm1'"), std::string::npos);
}

TEST(BusLoad, FdArmBus) {
  CanConfig c = fd5_layout();
  ASSERT_EQ(c.buses.size(), 5u);
  EXPECT_NEAR(worst_case_load(c.buses[4], 1000.0).load, 0.756, 1e-9);  // 7 * 108 us
  EXPECT_EQ(worst_case_load(c.buses[4], 1000.0).frames_per_tick, 14);
  c.buses[4].data_bitrate = 8000000;
  EXPECT_NEAR(worst_case_load(c.buses[4], 1000.0).load, 0.646, 1e-3);  // 7 * 92.3 us
  EXPECT_EQ(check_bus_loads(c), "");
  // The same seven joints on a classic bus: 175 %.
  c.buses[4].fd = false;
  EXPECT_NEAR(worst_case_load(c.buses[4], 1000.0).load, 1.75, 1e-12);
  EXPECT_NE(check_bus_loads(c).find("bus 'arm'"), std::string::npos);
}

}  // namespace
}  // namespace springbok::can
