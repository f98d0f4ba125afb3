#include <gtest/gtest.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

#include "springbok/rt/log.hpp"
#include "springbok/rt/spsc_ring.hpp"

namespace springbok::rt {
namespace {

TEST(SpscRing, FifoOrderAndCountedDropsWhenFull) {
  SpscRing<int, 4> ring;
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(ring.push(i));
  EXPECT_FALSE(ring.push(99));  // full: the newest is dropped, never blocks
  EXPECT_FALSE(ring.push(100));
  EXPECT_EQ(ring.dropped(), 2u);
  int v = -1;
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(ring.pop(v));
    EXPECT_EQ(v, i);
  }
  EXPECT_FALSE(ring.pop(v));
  EXPECT_TRUE(ring.push(5));  // wraps around
  ASSERT_TRUE(ring.pop(v));
  EXPECT_EQ(v, 5);
}

TEST(SpscRing, TwoThreadsLoseNothingButCountedDrops) {
  // The producer never waits; every record is either received in order or counted as dropped.
  auto ring = std::make_unique<SpscRing<std::uint64_t, 64>>();
  constexpr std::uint64_t kN = 200'000;
  std::atomic<bool> done{false};
  std::uint64_t received = 0, last = 0, out_of_order = 0;
  std::thread consumer([&] {
    std::uint64_t v = 0;
    for (;;) {
      if (ring->pop(v)) {
        if (received > 0 && v <= last) ++out_of_order;
        last = v;
        ++received;
      } else if (done.load(std::memory_order_acquire)) {
        if (!ring->pop(v)) break;
        last = v;
        ++received;
      }
    }
  });
  for (std::uint64_t i = 1; i <= kN; ++i) ring->push(i);
  done.store(true, std::memory_order_release);
  consumer.join();
  EXPECT_EQ(received + ring->dropped(), kN);
  EXPECT_EQ(out_of_order, 0u);
  EXPECT_GT(received, 0u);
}

// A FILE* that writes to memory (open_memstream); text() closes it and gives what was written.
class MemoryFile {
 public:
  MemoryFile() : file_(open_memstream(&text_, &size_)) {}
  MemoryFile(const MemoryFile&) = delete;
  MemoryFile& operator=(const MemoryFile&) = delete;
  ~MemoryFile() {
    close();
    std::free(text_);
  }
  std::FILE* get() const { return file_; }
  std::string text() {
    close();
    return std::string(text_, size_);
  }

 private:
  void close() {
    if (file_ != nullptr) std::fclose(file_);
    file_ = nullptr;
  }
  char* text_ = nullptr;
  std::size_t size_ = 0;
  std::FILE* file_;
};

TEST(LogDrainer, WritesEveryRecordAndReportsDrops) {
  auto ring = std::make_unique<LogRing>();
  MemoryFile out;
  ASSERT_NE(out.get(), nullptr);
  // Fill beyond capacity before the drainer runs: exactly the overflow is dropped.
  for (std::uint64_t i = 0; i < LogRing::capacity() + 3; ++i) {
    ring->push(LogRecord{i, static_cast<std::int64_t>(i) * 1'000'000, LogEvent::overrun, 1, 2, 0.5});
  }
  {
    LogDrainer drainer(*ring, out.get(), 1);
    drainer.stop();
    EXPECT_EQ(drainer.written(), LogRing::capacity());
  }
  const std::string s = out.text();
  EXPECT_NE(s.find("tick=0 t_ns=0 overrun a=1 b=2 x=0.5\n"), std::string::npos);
  EXPECT_NE(s.find("tick=4095 "), std::string::npos);
  EXPECT_EQ(s.find("tick=4096 "), std::string::npos);
  EXPECT_NE(s.find("log: 3 records dropped"), std::string::npos);
}

TEST(LogDrainer, AppendsTheDescriptionOfARecord) {
  auto ring = std::make_unique<LogRing>();
  MemoryFile out;
  ASSERT_NE(out.get(), nullptr);
  ring->push(LogRecord{7, 0, LogEvent::fault_latched, 256, 256, 0.0});
  ring->push(LogRecord{8, 0, LogEvent::overrun, 1, 2, 0.0});
  {
    LogDrainer drainer(*ring, out.get(), 1, [](const LogRecord& r) {
      return r.event == LogEvent::fault_latched ? std::string("new=imu_lost") : std::string();
    });
    drainer.stop();
  }
  const std::string s = out.text();
  EXPECT_NE(s.find("tick=7 t_ns=0 fault_latched a=256 b=256 x=0 (new=imu_lost)\n"), std::string::npos) << s;
  EXPECT_NE(s.find("tick=8 t_ns=0 overrun a=1 b=2 x=0\n"), std::string::npos) << s;
}

}  // namespace
}  // namespace springbok::rt
