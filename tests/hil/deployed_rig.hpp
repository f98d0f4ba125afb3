// The HIL suite's deployed-binary rig: `springbok` as a child process, a line to its operator
// socket, the emulator's ground-truth trace (--truth-log), the time scale, waiting on the
// firmware, the stand-up through the operator socket and the trace while standing. Used by the HyQ + Gen3 suite (test_deployed.cpp) and any robot's (test_any_robot.cpp).
#pragma once

#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <memory>

#include "springbok/dynamics/dynamics.hpp"
#include "springbok/model/model.hpp"
#include "template_oracle.hpp"

namespace springbok::can::hil {

// The deployed binary as a child process; stdout and stderr into one file.
class Firmware {
 public:
  Firmware(const std::string& config, int time_scale) {
    out_ = "/tmp/springbok_fw_out_" + std::to_string(::getpid());
    std::vector<std::string> args{std::string(SPRINGBOK_BIN_DIR) + "/springbok", "--config", config, "--time-scale",
                                  std::to_string(time_scale)};
    pid_ = ::fork();
    if (pid_ == 0) {
      std::freopen(out_.c_str(), "w", stdout);
      ::dup2(::fileno(stdout), 2);
      std::vector<char*> argv;
      for (std::string& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
  }
  ~Firmware() { stop(); }
  bool running() {
    int status = 0;
    return pid_ > 0 && ::waitpid(pid_, &status, WNOHANG) == 0;
  }
  // SIGTERM (orderly stop: damping, drives disabled); returns everything it printed.
  std::string stop() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      ::waitpid(pid_, &status_, 0);
      pid_ = -1;
      std::ifstream in(out_);
      std::stringstream ss;
      ss << in.rdbuf();
      output_ = ss.str();
      ::unlink(out_.c_str());
    }
    return output_;
  }
  int exit_status() const { return status_; }

 private:
  pid_t pid_ = -1;
  int status_ = -1;
  std::string out_, output_;
};

// One line to the operator socket, its one-line answer ("" when the socket is not there).
inline std::string operator_line(const std::string& socket_path, const std::string& line) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", socket_path.c_str());
  std::string reply;
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0) {
    const std::string msg = line + "\n";
    if (::write(fd, msg.data(), msg.size()) == static_cast<ssize_t>(msg.size())) {
      char c = 0;
      while (::read(fd, &c, 1) == 1 && c != '\n') reply += c;
    }
  }
  ::close(fd);
  return reply;
}

// One line of the emulator's ground-truth trace (--truth-log; bullet_motion.hpp names the columns).
struct TruthSample {
  double t_s = 0.0, trunk_z_m = 0.0, tilt_rad = 0.0;
  int non_foot_contact = 0;
  double trunk_x_m = 0.0, trunk_y_m = 0.0;
  Vec3 hand_m = Vec3::Zero(), hand_force_n = Vec3::Zero();
  int foot_contacts = 0;  // bit per foot: lf 1, rf 2, lh 4, rh 8
  char command = 'o';     // what the drives were told: o off, z zero torque, d damping, p position PD, t torque
  unsigned long long step = 0;
};

// The emulator's ground-truth trace, as far as it is written (a partial last line is skipped).
inline std::vector<TruthSample> read_truth(const std::string& path) {
  std::vector<TruthSample> out;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    TruthSample t;
    double hx, hy, hz, fx, fy, fz;
    if (std::sscanf(line.c_str(), "%lf %lf %lf %d %lf %lf %lf %lf %lf %lf %lf %lf %d %c %llu", &t.t_s, &t.trunk_z_m,
                    &t.tilt_rad, &t.non_foot_contact, &t.trunk_x_m, &t.trunk_y_m, &hx, &hy, &hz, &fx, &fy, &fz,
                    &t.foot_contacts, &t.command, &t.step) != 15) {
      continue;
    }
    t.hand_m = Vec3(hx, hy, hz);
    t.hand_force_n = Vec3(fx, fy, fz);
    out.push_back(t);
  }
  return out;
}

// The time of the trace's last complete line (reads only the file's tail).
inline double truth_time(const std::string& path) {
  std::ifstream in(path, std::ios::ate);
  const std::streamoff size = in.tellg();
  if (size <= 0) return 0.0;
  in.seekg(std::max<std::streamoff>(0, size - 400));
  std::string tail((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t end = tail.rfind('\n');
  if (end == std::string::npos) return 0.0;
  const std::size_t start = tail.rfind('\n', end == 0 ? 0 : end - 1);
  if (start == std::string::npos) return 0.0;
  return std::atof(tail.c_str() + start + 1);
}

// The deployed binary's --time-scale: SPRINGBOK_HIL_TIME_SCALE or `fallback`.
inline int hil_time_scale(int fallback) {
  const char* env = std::getenv("SPRINGBOK_HIL_TIME_SCALE");
  return env != nullptr ? std::atoi(env) : fallback;
}

// Waits (wall clock) until done() or the firmware exits or `limit_s` passes.
template <class Done>
bool wait_for(Firmware& fw, double limit_s, Done&& done) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(limit_s);
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    if (!fw.running()) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  return false;
}

// The trunk height over flat ground for these joint angles with the trunk level: the lowest
// foot sphere touches the ground (springbok::dyn forward kinematics).
inline double standing_height_m(const VecNj& q_joints) {
  const dyn::Model model;
  auto data = std::make_unique<dyn::Data>();
  VecNq q = VecNq::Zero();
  q[6] = 1.0;
  q.tail<kNj>() = q_joints;
  dyn::forward_kinematics(model, *data, q);
  double lowest = 0.0;
  for (int f = 0; f < kFeet; ++f) {
    lowest = std::min(lowest, data->frames[static_cast<std::size_t>(kFootFrames[static_cast<std::size_t>(f)])].translation.z());
  }
  return kFootRadius_m - lowest;
}

// The stand-up through the operator socket: `start` as soon as the firmware listens (idle only
// damps; the robot spawns on its feet, folded), then the status until the stand or damping mode.
struct StandUp {
  std::string started;    // the reply to `start` ("" : the firmware never listened)
  double first_z_m = 0;   // the trunk's height at the trace's first sample
  std::string status;     // the last status line
  bool ok() const { return started.rfind("ok", 0) == 0 && status.find("mode=stand ") != std::string::npos; }
};
inline StandUp stand_up(Firmware& fw, const std::string& socket_path, const std::string& truth, double limit_s) {
  StandUp s;
  if (!wait_for(fw, 120.0, [&] { return !(s.started = operator_line(socket_path, "start")).empty(); })) return s;
  if (!wait_for(fw, 60.0, [&] { return !read_truth(truth).empty(); })) return s;
  s.first_z_m = read_truth(truth).front().trunk_z_m;
  wait_for(fw, limit_s, [&] {
    s.status = operator_line(socket_path, "status");
    return s.status.find("mode=stand ") != std::string::npos || s.status.find("mode=damping") != std::string::npos;
  });
  return s;
}

// The trace over [from_s, to_s]: the trunk's height range (and over [settled_from_s, to_s]), the
// largest tilt, the samples with a non-foot contact, the feet that left the ground.
struct Standing {
  int samples = 0, non_foot = 0;
  double z_min = 1e9, z_max = -1e9, z_min_settled = 1e9, z_max_settled = -1e9, tilt_max = 0.0;
  std::array<bool, kFeet> lifted{};
};
inline Standing standing(const std::vector<TruthSample>& trace, double from_s, double to_s, double settled_from_s) {
  Standing s;
  for (const TruthSample& t : trace) {
    if (t.t_s < from_s || t.t_s > to_s) continue;
    ++s.samples;
    s.z_min = std::min(s.z_min, t.trunk_z_m);
    s.z_max = std::max(s.z_max, t.trunk_z_m);
    s.tilt_max = std::max(s.tilt_max, t.tilt_rad);
    s.non_foot += t.non_foot_contact;
    for (int f = 0; f < kFeet; ++f) s.lifted[static_cast<std::size_t>(f)] |= (t.foot_contacts & (1 << f)) == 0;
    if (t.t_s >= settled_from_s) {
      s.z_min_settled = std::min(s.z_min_settled, t.trunk_z_m);
      s.z_max_settled = std::max(s.z_max_settled, t.trunk_z_m);
    }
  }
  return s;
}

// The operator's path to the control mode: start (the stand-up), stand within `stand_up_s`
// simulated seconds, the wrist F/T tared, mode control. Returns the simulated time control was
// entered (< 0: it was not, and `why` says what stopped it).
inline double enter_control(Firmware& fw, const std::string& socket_path, const std::string& truth, double stand_up_s,
                            double wall_per_sim_s, std::string& why) {
  std::string reply;
  if (!wait_for(fw, 120.0, [&] { return !(reply = operator_line(socket_path, "start")).empty(); })) {
    why = "no operator socket";
    return -1.0;
  }
  if (reply.rfind("ok start", 0) != 0) {
    why = reply;
    return -1.0;
  }
  if (!wait_for(fw, (stand_up_s + 1.0) * wall_per_sim_s, [&] {
        reply = operator_line(socket_path, "status");
        return reply.find("mode=stand ") != std::string::npos || reply.find("mode=damping") != std::string::npos;
      }) ||
      reply.find("mode=stand ") == std::string::npos) {
    why = "no stand: " + reply;
    return -1.0;
  }
  if (!wait_for(fw, 2.0 * wall_per_sim_s, [&] {
        reply = operator_line(socket_path, "controller");
        return reply.find("tare=done") != std::string::npos;
      })) {
    why = "no tare: " + reply;
    return -1.0;
  }
  reply = operator_line(socket_path, "mode control");
  if (reply.rfind("ok mode control", 0) != 0) {
    why = reply;
    return -1.0;
  }
  return truth_time(truth);
}

// A push along x at the hand over [start_s, end_s], scored against the template driven by the
// force on the hand (what the tared F/T measures), integrated from rest at the push's start;
// the trunk's and the hand's displacements from their means over the 0.1 s before it.
// `samples` 0: the trace holds no pose before the push.
inline test::PushScore score_push(const std::vector<TruthSample>& trace, const test::TemplateAxis& axis, double start_s,
                                  double end_s) {
  test::PushScore score(axis, start_s, end_s, 0.5);
  double base0 = 0.0, hand0 = 0.0;
  int n0 = 0;
  for (const TruthSample& t : trace) {
    if (t.t_s >= start_s - 0.1 && t.t_s < start_s) {
      base0 += t.trunk_x_m;
      hand0 += t.hand_m.x();
      ++n0;
    }
  }
  if (n0 < 50) return score;
  base0 /= n0;
  hand0 /= n0;
  for (const TruthSample& t : trace) score.add(t.t_s, t.hand_force_n.x(), t.trunk_x_m - base0, t.hand_m.x() - hand0);
  return score;
}

}  // namespace springbok::can::hil
