#include "springbok/app/flight_recorder.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>

#include "springbok/yaml/reader.hpp"

namespace springbok::app {

RecorderConfig read_recorder_config(const yaml::Field& f) {
  RecorderConfig c;
  if (!f.present() || !f.allow_only({"enabled", "seconds", "dir"})) return c;
  f["enabled"].boolean(c.enabled);
  f["seconds"].number(c.seconds, 1.0, 300.0);
  if (f["dir"].text(c.dir) && c.dir.empty()) f["dir"].fail("must name a directory");
  return c;
}

const char* to_string(DumpReason reason) noexcept {
  switch (reason) {
    case DumpReason::none: return "none";
    case DumpReason::fault: return "fault";
    case DumpReason::stop: return "stop";
    case DumpReason::operator_request: return "operator";
  }
  return "unknown";
}

FlightRecorder::FlightRecorder(std::size_t capacity, std::string dir)
    : slots_(capacity < 1 ? 1 : capacity), dir_(std::move(dir)) {
  copy_.reserve(slots_.size());
}

FlightRecorder::~FlightRecorder() { stop(); }

// rt: no alloc, no block
void FlightRecorder::record(const TelemetryRecord& r) noexcept {
  const std::uint64_t k = head_.load(std::memory_order_relaxed);
  Slot& s = slots_[static_cast<std::size_t>(k % slots_.size())];
  s.sequence.store(2 * k + 1, std::memory_order_relaxed);
  std::atomic_thread_fence(std::memory_order_release);
  s.record = r;
  s.sequence.store(2 * k + 2, std::memory_order_release);
  head_.store(k + 1, std::memory_order_release);
}

// rt: no alloc, no block
void FlightRecorder::request(DumpReason reason) noexcept {
  std::uint8_t none = 0;
  (void)pending_.compare_exchange_strong(none, static_cast<std::uint8_t>(reason), std::memory_order_acq_rel);
}

// Newest first: the RT side overwrites the oldest slots, so a copy that walks away from it
// loses at most the oldest end of the ring to a fast writer (walking oldest first, a writer
// faster than the copy overwrites every slot just before it is read). The first slot found
// overwritten ends the walk: the writer goes in order, so every older slot is gone too.
std::size_t FlightRecorder::snapshot() {
  const std::uint64_t n = slots_.size();
  for (int attempt = 0; attempt < 100; ++attempt) {
    copy_.clear();
    const std::uint64_t head = head_.load(std::memory_order_acquire);
    const std::uint64_t oldest = head > n ? head - n : 0;
    for (std::uint64_t k = head; k > oldest; --k) {
      const Slot& s = slots_[static_cast<std::size_t>((k - 1) % n)];
      const std::uint64_t whole = 2 * (k - 1) + 2;
      if (s.sequence.load(std::memory_order_acquire) != whole) break;  // overwritten since
      copy_.push_back(s.record);
      std::atomic_thread_fence(std::memory_order_acquire);
      if (s.sequence.load(std::memory_order_relaxed) != whole) {  // written over meanwhile
        copy_.pop_back();
        break;
      }
    }
    // Nothing whole although ticks were recorded: the copy was lapped at its first slot (its
    // thread preempted for a whole ring's worth of ticks); look again.
    if (!copy_.empty() || head == 0) break;
  }
  std::reverse(copy_.begin(), copy_.end());
  return copy_.size();
}

std::string FlightRecorder::write(DumpReason reason, std::string& error) {
  const std::lock_guard<std::mutex> lock(write_mutex_);
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = snapshot();
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%dT%H%M%SZ", &utc);
  const std::uint64_t number = files_.load(std::memory_order_relaxed) + 1;
  const std::string path = dir_ + "/flight-" + stamp + "-" + std::to_string(number) + "-" + to_string(reason) + ".csv";
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) {
    error = "flight recorder: cannot write " + path;
    return "";
  }
  std::string chunk = telemetry_csv_header() + "\n";
  chunk.reserve(1 << 20);
  for (std::size_t i = 0; i < n; ++i) {
    append_telemetry_csv_row(chunk, copy_[i]);
    if (chunk.size() > (1 << 20) - 8192) {
      std::fwrite(chunk.data(), 1, chunk.size(), f);
      chunk.clear();
    }
  }
  std::fwrite(chunk.data(), 1, chunk.size(), f);  // the rest (the header alone of an empty ring)
  const bool ok = std::fflush(f) == 0 && std::ferror(f) == 0;
  std::fclose(f);
  if (!ok) {
    error = "flight recorder: error writing " + path;
    return "";
  }
  last_file_ = path;
  files_.fetch_add(1, std::memory_order_relaxed);
  last_write_s_.store(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                      std::memory_order_relaxed);
  return path;
}

std::string FlightRecorder::last_file() const {
  const std::lock_guard<std::mutex> lock(write_mutex_);
  return last_file_;
}

void FlightRecorder::run() {
  while (!stop_.load(std::memory_order_acquire)) {
    // Taken before the write: a request while it writes gets a file of its own.
    const auto reason = static_cast<DumpReason>(pending_.exchange(0, std::memory_order_acq_rel));
    if (reason != DumpReason::none) {
      std::string error;
      const std::string path = write(reason, error);
      if (path.empty()) {
        std::fprintf(stderr, "springbok: %s\n", error.c_str());
      } else {
        std::fprintf(stderr, "springbok: flight recorder (%s): %s\n", to_string(reason), path.c_str());
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

void FlightRecorder::start() {
  stop_.store(false);
  thread_ = std::thread([this] { run(); });
}

void FlightRecorder::stop() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

}  // namespace springbok::app
