#include "event_source.hpp"

#include <fcntl.h>
#include <libevdev/libevdev.h>
#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <chrono>
#include <cstring>
#include <fstream>
#include <sstream>
#include <thread>


namespace springbok::teleop {
namespace {

class DeviceSource final : public EventSource {
 public:
  DeviceSource(int fd, libevdev* dev, std::string path) : fd_(fd), dev_(dev), path_(std::move(path)) {}
  ~DeviceSource() override {
    libevdev_free(dev_);
    ::close(fd_);
  }

  Next next(double timeout_s, InputEvent& out) override {
    for (;;) {
      input_event ev{};
      const int flag = syncing_ ? LIBEVDEV_READ_FLAG_SYNC : LIBEVDEV_READ_FLAG_NORMAL;
      const int rc = libevdev_next_event(dev_, flag, &ev);
      if (rc == LIBEVDEV_READ_STATUS_SUCCESS || rc == LIBEVDEV_READ_STATUS_SYNC) {
        // SYNC: the kernel dropped events (SYN_DROPPED); libevdev replays the device's state.
        syncing_ = rc == LIBEVDEV_READ_STATUS_SYNC;
        out = {ev.type, ev.code, ev.value};
        return Next::event;
      }
      if (syncing_ && rc == -EAGAIN) {
        syncing_ = false;
        continue;
      }
      if (rc != -EAGAIN) return Next::gone;  // -ENODEV: unplugged
      pollfd p{fd_, POLLIN, 0};
      const int ms = static_cast<int>(std::max(0.0, timeout_s) * 1000.0);
      const int n = ::poll(&p, 1, ms);
      if (n == 0) return Next::none;
      if (n < 0 && errno == EINTR) return Next::none;
      if (n < 0 || (p.revents & (POLLERR | POLLHUP | POLLNVAL)) != 0) return Next::gone;
    }
  }

  std::vector<std::pair<int, AxisRange>> axes() const override {
    std::vector<std::pair<int, AxisRange>> out;
    for (int code = 0; code <= ABS_MAX; ++code) {
      if (libevdev_has_event_code(dev_, EV_ABS, static_cast<unsigned>(code)) == 0) continue;
      out.emplace_back(code, AxisRange{libevdev_get_abs_minimum(dev_, static_cast<unsigned>(code)),
                                       libevdev_get_abs_maximum(dev_, static_cast<unsigned>(code))});
    }
    return out;
  }

  std::string name() const override {
    const char* n = libevdev_get_name(dev_);
    return std::string(n != nullptr ? n : "unnamed") + " (" + path_ + ")";
  }

 private:
  int fd_;
  libevdev* dev_;
  std::string path_;
  bool syncing_ = false;
};

struct Recorded {
  double t_s;
  bool unplug;
  InputEvent event;
};

class RecordingSource final : public EventSource {
 public:
  RecordingSource(std::vector<Recorded> items, std::vector<std::pair<int, AxisRange>> axes, std::string path)
      : items_(std::move(items)), axes_(std::move(axes)), path_(std::move(path)),
        start_(std::chrono::steady_clock::now()) {}

  Next next(double timeout_s, InputEvent& out) override {
    if (gone_ || next_ >= items_.size()) {
      gone_ = true;
      return Next::gone;
    }
    const Recorded& r = items_[next_];
    const auto due = start_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                  std::chrono::duration<double>(r.t_s));
    const auto wait_until =
        std::chrono::steady_clock::now() +
        std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(std::max(0.0, timeout_s)));
    if (due > wait_until) {
      std::this_thread::sleep_until(wait_until);
      return Next::none;
    }
    std::this_thread::sleep_until(due);
    ++next_;
    if (r.unplug) {
      gone_ = true;
      return Next::gone;
    }
    out = r.event;
    return Next::event;
  }

  std::vector<std::pair<int, AxisRange>> axes() const override { return axes_; }
  std::string name() const override { return "recorded stream " + path_; }

 private:
  std::vector<Recorded> items_;
  std::vector<std::pair<int, AxisRange>> axes_;
  std::string path_;
  std::chrono::steady_clock::time_point start_;
  std::size_t next_ = 0;
  bool gone_ = false;
};

}  // namespace

std::unique_ptr<EventSource> open_device(const std::string& path, std::string& error) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    error = "cannot open " + path + ": " + std::strerror(errno);
    return nullptr;
  }
  libevdev* dev = nullptr;
  const int rc = libevdev_new_from_fd(fd, &dev);
  if (rc < 0) {
    error = path + " is not an input device: " + std::strerror(-rc);
    ::close(fd);
    return nullptr;
  }
  return std::make_unique<DeviceSource>(fd, dev, path);
}

std::unique_ptr<EventSource> open_recording(const std::string& path, std::string& error) {
  std::ifstream in(path);
  if (!in) {
    error = "cannot read " + path;
    return nullptr;
  }
  std::vector<Recorded> items;
  std::vector<std::pair<int, AxisRange>> axes;
  std::string line;
  double last_t_s = 0.0;
  for (int number = 1; std::getline(in, line); ++number) {
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    std::istringstream words(line);
    std::string first;
    if (!(words >> first)) continue;
    const auto fail = [&](const std::string& why) {
      error = path + ":" + std::to_string(number) + ": " + why;
      return nullptr;
    };
    std::string extra;
    if (first == "axis") {
      std::string name;
      AxisRange r;
      if (!(words >> name >> r.min >> r.max) || (words >> extra)) return fail("expected 'axis ABS_NAME MIN MAX'");
      const int code = libevdev_event_code_from_name(EV_ABS, name.c_str());
      if (code < 0) return fail("unknown axis '" + name + "'");
      if (r.min >= r.max) return fail("the axis's MIN must be below its MAX");
      axes.emplace_back(code, r);
      continue;
    }
    Recorded r{};
    char* end = nullptr;
    r.t_s = std::strtod(first.c_str(), &end);
    if (end == first.c_str() || *end != '\0' || !(r.t_s >= 0.0) || r.t_s > 1e6) {
      return fail("expected a time in seconds (0 to 1e6), got '" + first + "'");
    }
    if (r.t_s < last_t_s) return fail("times must not decrease");
    last_t_s = r.t_s;
    std::string type, code;
    if (!(words >> type)) return fail("expected 'TYPE CODE VALUE' or 'unplug' after the time");
    if (type == "unplug") {
      if (words >> extra) return fail("nothing may follow 'unplug'");
      r.unplug = true;
      items.push_back(r);
      continue;
    }
    if (!(words >> code >> r.event.value) || (words >> extra)) return fail("expected 'TYPE CODE VALUE'");
    r.event.type = libevdev_event_type_from_name(type.c_str());
    if (r.event.type < 0) return fail("unknown event type '" + type + "'");
    r.event.code = libevdev_event_code_from_name(static_cast<unsigned>(r.event.type), code.c_str());
    if (r.event.code < 0) return fail("unknown " + type + " code '" + code + "'");
    items.push_back(r);
  }
  return std::make_unique<RecordingSource>(std::move(items), std::move(axes), path);
}

std::string format_event(double t_s, const InputEvent& e) {
  const char* type = libevdev_event_type_get_name(static_cast<unsigned>(e.type));
  const char* code = libevdev_event_code_get_name(static_cast<unsigned>(e.type), static_cast<unsigned>(e.code));
  char buf[128];
  std::snprintf(buf, sizeof buf, "%.3f %s %s %d", t_s, type != nullptr ? type : "EV_UNKNOWN",
                code != nullptr ? code : "UNKNOWN", e.value);
  return buf;
}

std::string format_unplug(double t_s) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.3f unplug", t_s);
  return buf;
}

std::string axis_name(int code) {
  const char* name = libevdev_event_code_get_name(EV_ABS, static_cast<unsigned>(code));
  return name != nullptr ? std::string(name) : "ABS_" + std::to_string(code);
}

}  // namespace springbok::teleop
