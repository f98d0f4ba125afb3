#include "springbok/app/operator_server.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <vector>

namespace springbok::app {
namespace {

struct Client {
  int fd = -1;
  std::string buffer;
};

void send_line(int fd, const std::string& text) {
  const std::string line = text + "\n";
  // Non-blocking, no SIGPIPE: a client that does not read loses its reply.
  (void)::send(fd, line.data(), line.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
}

}  // namespace

OperatorServer::OperatorServer(OperatorMailbox& mailbox, LoopStatus& status, const rt::PublishedStats& stats)
    : mailbox_(mailbox), status_(status), stats_(stats) {}

OperatorServer::~OperatorServer() {
  stop();
  if (listen_fd_ >= 0) {
    ::close(listen_fd_);
    ::unlink(path_.c_str());
  }
}

std::string OperatorServer::open(const std::string& socket_path) {
  sockaddr_un addr{};
  if (socket_path.empty() || socket_path.size() >= sizeof addr.sun_path) {
    return "operator.socket: path empty or longer than " + std::to_string(sizeof addr.sun_path - 1) + " bytes";
  }
  struct stat st{};
  if (::lstat(socket_path.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode)) return "operator.socket: " + socket_path + " exists and is not a socket";
    ::unlink(socket_path.c_str());  // stale socket of an earlier run
  }
  listen_fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0) return std::string("operator socket: ") + std::strerror(errno);
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, socket_path.c_str(), socket_path.size() + 1);
  if (::bind(listen_fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0 ||
      ::listen(listen_fd_, kMaxClients) != 0) {
    const std::string why = std::strerror(errno);
    ::close(listen_fd_);
    listen_fd_ = -1;
    return "operator.socket: " + socket_path + ": " + why;
  }
  ::chmod(socket_path.c_str(), 0660);
  path_ = socket_path;
  return {};
}

void OperatorServer::start() {
  stop_.store(false);
  thread_ = std::thread([this] { run(); });
}

void OperatorServer::stop() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

std::string OperatorServer::status_line() const {
  const auto mode = static_cast<safety::Mode>(status_.mode.load(std::memory_order_relaxed));
  const safety::FaultMask faults = status_.faults.load(std::memory_order_relaxed);
  char numbers[256];
  std::snprintf(numbers, sizeof numbers,
                " ticks=%llu overruns=%llu skipped=%llu max_wake_latency_us=%.1f max_compute_us=%.1f "
                "stale_ticks=%u hal_errors=%llu",
                static_cast<unsigned long long>(stats_.ticks.load()),
                static_cast<unsigned long long>(stats_.overruns.load()),
                static_cast<unsigned long long>(stats_.skipped_ticks.load()),
                static_cast<double>(stats_.max_wake_latency_ns.load()) / 1e3,
                static_cast<double>(stats_.max_compute_ns.load()) / 1e3, status_.stale_ticks.load(),
                static_cast<unsigned long long>(status_.hal_errors.load()));
  std::string line =
      std::string("ok status mode=") + safety::to_string(mode) + " faults=" + fault_list(faults) + numbers;
  // Which joint to bring back inside its limits before a reset is accepted.
  if (const int joint = status_.limit_joint.load(std::memory_order_acquire); joint >= 0 && joint < kNj) {
    char where[128];
    std::snprintf(where, sizeof where, " limit_joint=%.*s q_rad=%.4f",
                  static_cast<int>(robot::kJoints[static_cast<std::size_t>(joint)].name.size()),
                  robot::kJoints[static_cast<std::size_t>(joint)].name.data(),
                  status_.limit_joint_position_rad.load(std::memory_order_relaxed));
    line += where;
  }
  return line;
}

// "lf,rh" (the feet on the ground) or "none".
static std::string stance_list(const Stance& stance) {
  static constexpr const char* kFootNames[kFeet] = {"lf", "rf", "lh", "rh"};
  std::string out;
  for (int f = 0; f < kFeet; ++f) {
    if (!stance[static_cast<std::size_t>(f)]) continue;
    if (!out.empty()) out += ',';
    out += kFootNames[f];
  }
  return out.empty() ? "none" : out;
}

std::string OperatorServer::controller_line() {
  ControllerSnapshot snapshot;
  if (!status_.controller.read(snapshot)) return "error: controller: no state published yet";
  if (!snapshot.wbc) return "ok controller controller=joint_pd";
  const control::TickReport& c = snapshot.report;
  // The base estimate's position and its velocity in world axes.
  const Quat orientation = Quat(c.base_pose[6], c.base_pose[3], c.base_pose[4], c.base_pose[5]).normalized();
  const Vec3 p = c.base_pose.head<3>(), v = orientation * c.base_twist.head<3>();
  char text[768];
  const control::Tare& t = c.tare;
  std::snprintf(
      text, sizeof text,
      "ok controller controller=wbc engaged=%d gait=%s step_frequency=%.3g duty_factor=%.3g stance=%s "
      "last_tick=%s failed_ticks=%llu stance_changes=%llu tare=%s tares=%u tare_force_n=%.3f,%.3f,%.3f "
      "wrist_force_n=%.3f,%.3f,%.3f base_position_m=%.4f,%.4f,%.4f base_velocity_m_s=%.4f,%.4f,%.4f "
      "stepping_for_push=%d gyro_bias_rad_s=%.5f,%.5f,%.5f gyro_calibrated_s=%.1f",
      c.engaged ? 1 : 0, control::to_string(c.gait), c.trot.step_frequency_hz, c.trot.duty_factor,
      stance_list(c.stance).c_str(), control::to_string(c.status), static_cast<unsigned long long>(c.failed_ticks),
      static_cast<unsigned long long>(c.stance_changes), t.running ? "collecting" : (t.completed > 0 ? "done" : "none"),
      t.completed, t.force_n.x(), t.force_n.y(), t.force_n.z(), c.wrist_force_n.x(), c.wrist_force_n.y(),
      c.wrist_force_n.z(), p.x(), p.y(), p.z(), v.x(), v.y(), v.z(), c.stepping_for_push ? 1 : 0,
      c.gyro_bias_i_rad_s.x(), c.gyro_bias_i_rad_s.y(), c.gyro_bias_i_rad_s.z(), c.gyro_calibrated_s);
  return text;
}

// One request through the mailbox; the verdict, or a timeout that cancels it.
std::string OperatorServer::exchange(OperatorRequest request, const std::string& name) {
  request.id = next_id_++;
  if (!mailbox_.requests.push(request)) return "error: " + name + ": mailbox full, command dropped";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(kReplyTimeoutMs);
  OperatorReply reply;
  while (std::chrono::steady_clock::now() < deadline) {
    while (mailbox_.replies.pop(reply)) {
      if (reply.id != request.id) continue;  // the late verdict of a request that timed out
      const std::string state = std::string(" (mode=") + safety::to_string(reply.mode) +
                                " faults=" + fault_list(reply.faults) + ")";
      if (reply.accepted) return "ok " + name + state;
      return "error: " + name + ": " + (reply.refusal != nullptr ? reply.refusal : "refused") + state;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  mailbox_.first_valid_id.store(request.id + 1, std::memory_order_release);  // never apply it later
  return "error: " + name + ": controller not responding, command dropped";
}

std::string OperatorServer::handle_line(std::string_view line) {
  const ParsedLine parsed = parse_operator_line(line);
  OperatorRequest request;
  switch (parsed.kind) {
    case ParsedLine::Kind::error: return parsed.error;
    case ParsedLine::Kind::status: return status_line();
    case ParsedLine::Kind::controller_status: return controller_line();
    case ParsedLine::Kind::dump: {
      if (recorder_ == nullptr) return "error: dump: the flight recorder is off (recorder.enabled)";
      std::string error;
      const std::string path = recorder_->write(DumpReason::operator_request, error);
      if (path.empty()) return "error: dump: " + error;
      return "ok dump " + path;
    }
    case ParsedLine::Kind::command:
      request.command = parsed.command;
      break;
    case ParsedLine::Kind::controller_request:
      request.for_controller = true;
      request.request = parsed.request;
      break;
  }
  return exchange(request, parsed.name);
}

void OperatorServer::run() {
  std::vector<Client> clients;
  while (!stop_.load()) {
    std::vector<pollfd> fds;
    fds.push_back({listen_fd_, POLLIN, 0});
    for (const Client& c : clients) fds.push_back({c.fd, POLLIN, 0});
    if (::poll(fds.data(), fds.size(), 50) <= 0) continue;

    if ((fds[0].revents & POLLIN) != 0) {
      const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd >= 0) {
        if (static_cast<int>(clients.size()) >= kMaxClients) {
          send_line(fd, "error: too many operator clients");
          ::close(fd);
        } else {
          clients.push_back({fd, {}});
        }
      }
    }
    for (std::size_t i = 1; i < fds.size(); ++i) {
      if (fds[i].revents == 0) continue;
      Client& c = clients[i - 1];
      char chunk[512];
      const ssize_t n = ::recv(c.fd, chunk, sizeof chunk, MSG_DONTWAIT);
      if (n <= 0) {
        if (n == 0 || (errno != EAGAIN && errno != EINTR)) {
          ::close(c.fd);
          c.fd = -1;
        }
        continue;
      }
      c.buffer.append(chunk, static_cast<std::size_t>(n));
      std::size_t newline;
      while (c.fd >= 0 && (newline = c.buffer.find('\n')) != std::string::npos) {
        const std::string line = c.buffer.substr(0, newline);
        c.buffer.erase(0, newline + 1);
        send_line(c.fd, handle_line(line));
      }
      if (c.fd >= 0 && c.buffer.size() > kMaxOperatorLine + 1) {
        send_line(c.fd, "error: line too long (at most 255 bytes)");
        ::close(c.fd);
        c.fd = -1;
      }
    }
    std::erase_if(clients, [](const Client& c) { return c.fd < 0; });
  }
  for (const Client& c : clients) ::close(c.fd);
}

}  // namespace springbok::app
