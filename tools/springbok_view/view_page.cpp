#include "view_page.hpp"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>

#include "springbok/dynamics/dynamics.hpp"
#include "springbok/model/model.hpp"

namespace springbok::view {
namespace {

constexpr const char* kFootNames[kFeet] = {"lf", "rf", "lh", "rh"};
constexpr const char* kAxes[3] = {"x", "y", "z"};

// A number for the page: fixed, 6 decimals (1 um, 1 urad, 1 uN), trailing zeros dropped.
void append_number(std::string& out, double value) {
  if (!std::isfinite(value)) {  // JSON has no NaN: the page draws 0 and the file says so
    out += "null";
    return;
  }
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, value, std::chars_format::fixed, 6);
  const char* end = r.ptr;
  while (end > buf && end[-1] == '0') --end;
  if (end > buf && end[-1] == '.') --end;
  const char* begin = buf;
  if (end - begin == 2 && begin[0] == '-' && begin[1] == '0') ++begin;  // -0: a value above -5e-7
  out.append(begin, static_cast<std::size_t>(end - begin));
}

template <std::size_t N>
void append_numbers(std::string& out, const std::array<double, N>& values) {
  out += '[';
  for (std::size_t i = 0; i < N; ++i) {
    if (i > 0) out += ',';
    append_number(out, values[i]);
  }
  out += ']';
}

void append_transform(std::string& out, const model::Transform& t) {
  out += "{\"rotation\":";
  append_numbers(out, t.rotation);
  out += ",\"translation\":";
  append_numbers(out, t.translation);
  out += '}';
}

// A JSON string of `text`; '<' escaped so that no "</script" can end the page's script.
void append_string(std::string& out, std::string_view text) {
  out += '"';
  for (char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (c == '<') {
      out += "\\u003c";
    } else if (static_cast<unsigned char>(c) < 0x20) {
      out += fmt::format("\\u{:04x}", static_cast<unsigned>(c));
    } else {
      out += c;
    }
  }
  out += '"';
}

// ---- CSV --------------------------------------------------------------------------------------

struct Csv {
  std::filesystem::path path;
  std::map<std::string, int> column;  // name -> index; a repeated name: its last column
  int width = 0;
};

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> cells;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    cells.push_back(line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start));
    if (comma == std::string_view::npos) return cells;
    start = comma + 1;
  }
}

int require_column(const Csv& csv, const std::string& name) {
  const auto it = csv.column.find(name);
  if (it == csv.column.end()) throw Error(fmt::format("{}: no column '{}'", csv.path.string(), name));
  return it->second;
}

int optional_column(const Csv& csv, const std::string& name) {
  const auto it = csv.column.find(name);
  return it == csv.column.end() ? -1 : it->second;
}

// Reads every row; `keep(time, last)` says whether a row goes into the run; `row(time, number)`
// gets the kept rows, `number(column)` the value of a cell (checked to be a number).
template <class Keep, class Row>
void read_rows(std::istream& in, const Csv& csv, int time_column, Keep&& keep, Row&& row) {
  std::string line;
  for (int line_number = 2; std::getline(in, line); ++line_number) {
    if (line.empty()) continue;
    const auto cells = split(line);
    if (static_cast<int>(cells.size()) != csv.width) {
      throw Error(fmt::format("{}:{}: {} values, the header has {}", csv.path.string(), line_number, cells.size(),
                              csv.width));
    }
    const auto number = [&](int c) {
      const std::string_view cell = cells[static_cast<std::size_t>(c)];
      double v = 0.0;
      const auto r = std::from_chars(cell.data(), cell.data() + cell.size(), v);
      if (r.ec != std::errc{} || r.ptr != cell.data() + cell.size()) {
        throw Error(fmt::format("{}:{}: column '{}': '{}' is no number", csv.path.string(), line_number,
                                [&] {
                                  for (const auto& [name, index] : csv.column) {
                                    if (index == c) return name;
                                  }
                                  return std::to_string(c);
                                }(),
                                cell));
      }
      return v;
    };
    const double t = number(time_column);
    if (!keep(t, in.peek() == std::char_traits<char>::eof())) continue;
    row(t, number);
  }
}

// Keeps the first row and then one at or after each 1/rate_hz; the last row always.
struct Sampler {
  double period_s;
  double next_s = -1e300;
  bool operator()(double t, bool last) {
    if (t + 1e-9 < next_s && !last) return false;
    next_s = (next_s < -1e299 ? t : next_s) + period_s;
    while (next_s <= t + 1e-9) next_s += period_s;
    return true;
  }
};

std::vector<double>& series(Run& run, const std::string& name) {
  for (auto& [n, values] : run.series) {
    if (n == name) return values;
  }
  run.series.emplace_back(name, std::vector<double>{});
  return run.series.back().second;
}

// A springbok-sim log.csv: the simulator's truth for the robot, the controller's columns for
// the rest (the QP's ground forces, F_e, the template) when it is the whole-body controller.
Run load_sim_log(std::istream& in, Csv& csv, double rate_hz) {
  Run run;
  run.source = "springbok-sim log";
  const int time = require_column(csv, "time_s");
  std::array<int, 7> base{};
  {
    const char* names[7] = {"base_x_m", "base_y_m", "base_z_m", "base_qx", "base_qy", "base_qz", "base_qw"};
    for (int i = 0; i < 7; ++i) base[static_cast<std::size_t>(i)] = require_column(csv, names[i]);
  }
  std::array<int, kNj> q{};
  for (int j = 0; j < kNj; ++j) {
    q[static_cast<std::size_t>(j)] = require_column(csv, fmt::format("q_{}", robot::kJoints[static_cast<std::size_t>(j)].name));
  }
  // The whole-body controller's columns (absent for the stand and damping controllers): the
  // foot force columns then are the QP's (lf_fz_n's last column), else the simulator's z.
  const int wbc_active = optional_column(csv, "wbc_active");
  const auto triple = [&](const std::string& prefix, const std::string& suffix) {
    std::array<int, 3> c{};
    for (int a = 0; a < 3; ++a) c[static_cast<std::size_t>(a)] = optional_column(csv, prefix + kAxes[a] + suffix);
    return c;
  };
  std::array<std::array<int, 3>, kFeet> foot{};
  std::array<int, kFeet> stance{};
  for (int f = 0; f < kFeet; ++f) {
    foot[static_cast<std::size_t>(f)] = triple(std::string(kFootNames[f]) + "_f", "_n");
    stance[static_cast<std::size_t>(f)] = optional_column(csv, std::string(kFootNames[f]) + "_stance");
  }
  const auto fe = triple("fe_", "_n"), base_d = triple("base_d", "_m"), ee_d = triple("ee_d", "_m");
  const auto template_base = triple("template_base_", "_m"), template_ee = triple("template_ee_", "_m");

  const dyn::Model model;
  const auto data = std::make_unique<dyn::Data>();
  VecNq config = VecNq::Zero();
  Sampler sampler{1.0 / rate_hz};
  read_rows(in, csv, time, sampler, [&](double t, const auto& number) {
    const auto at = [&](int c) { return c < 0 ? 0.0 : number(c); };
    run.time_s.push_back(t);
    static constexpr const char* kBaseNames[7] = {"base_x_m", "base_y_m", "base_z_m", "base_qx",
                                                  "base_qy",  "base_qz",  "base_qw"};
    for (int i = 0; i < 7; ++i) {
      config[i] = at(base[static_cast<std::size_t>(i)]);
      series(run, kBaseNames[i]).push_back(config[i]);
    }
    for (int j = 0; j < kNj; ++j) {
      config[7 + j] = at(q[static_cast<std::size_t>(j)]);
      series(run, fmt::format("q_{}_rad", robot::kJoints[static_cast<std::size_t>(j)].name)).push_back(config[7 + j]);
    }
    for (int f = 0; f < kFeet; ++f) {
      for (int a = 0; a < 3; ++a) {
        series(run, fmt::format("{}_force_{}_n", kFootNames[f], kAxes[a]))
            .push_back(at(foot[static_cast<std::size_t>(f)][static_cast<std::size_t>(a)]));
      }
      series(run, fmt::format("{}_stance", kFootNames[f])).push_back(at(stance[static_cast<std::size_t>(f)]));
    }
    const bool active = wbc_active >= 0 && at(wbc_active) != 0.0;
    if (active) {
      config.segment<4>(3).normalize();
      dyn::forward_kinematics(model, *data, config);
    }
    const Vec3 hand = active ? data->frames[kEeFrame].translation : Vec3::Zero();
    for (int a = 0; a < 3; ++a) {
      const auto i = static_cast<std::size_t>(a);
      const double base_rest = active ? config[a] - at(base_d[i]) : 0.0;
      const double hand_rest = active ? hand[a] - at(ee_d[i]) : 0.0;
      series(run, fmt::format("fe_{}_n", kAxes[a])).push_back(at(fe[i]));
      series(run, fmt::format("hand_{}_m", kAxes[a])).push_back(hand[a]);
      series(run, fmt::format("base_rest_{}_m", kAxes[a])).push_back(base_rest);
      series(run, fmt::format("hand_rest_{}_m", kAxes[a])).push_back(hand_rest);
      series(run, fmt::format("base_displacement_{}_m", kAxes[a])).push_back(active ? at(template_base[i]) : 0.0);
      series(run, fmt::format("hand_displacement_{}_m", kAxes[a])).push_back(active ? at(template_ee[i]) : 0.0);
    }
  });
  return run;
}

// A flight-recorder file: the telemetry's columns already; the ones the page draws are kept.
Run load_recorder(std::istream& in, Csv& csv, double rate_hz) {
  Run run;
  run.source = "flight recorder";
  const int time = require_column(csv, "timestamp");
  std::vector<std::pair<std::string, int>> kept;
  const auto keep = [&](const std::string& name) { kept.emplace_back(name, require_column(csv, name)); };
  for (const char* n : {"base_x_m", "base_y_m", "base_z_m", "base_qx", "base_qy", "base_qz", "base_qw"}) keep(n);
  for (const auto& j : robot::kJoints) keep(fmt::format("q_{}_rad", j.name));
  for (const char* f : kFootNames) {
    for (const char* a : kAxes) keep(fmt::format("{}_force_{}_n", f, a));
    keep(fmt::format("{}_stance", f));
  }
  for (const char* name : {"fe", "hand", "base_rest", "hand_rest", "base_displacement", "hand_displacement"}) {
    for (const char* a : kAxes) keep(fmt::format("{}_{}_{}", name, a, std::string_view(name) == "fe" ? "n" : "m"));
  }
  for (const auto& [name, column] : kept) run.series.emplace_back(name, std::vector<double>{});
  Sampler sampler{1.0 / rate_hz};
  read_rows(in, csv, time, sampler, [&](double t, const auto& number) {
    run.time_s.push_back(t);
    for (std::size_t i = 0; i < kept.size(); ++i) {
      run.series[i].second.push_back(number(kept[i].second));
    }
  });
  return run;
}

}  // namespace

std::string robot_json() {
  std::string out = "{\"name\":";
  append_string(out, robot::kRobotName);
  out += fmt::format(",\"arm_first_joint\":{},\"joints\":[", kFirstArmJoint);
  for (std::size_t j = 0; j < robot::kJoints.size(); ++j) {
    const auto& joint = robot::kJoints[j];
    if (j > 0) out += ',';
    out += "{\"name\":";
    append_string(out, joint.name);
    out += fmt::format(",\"parent_body\":{},\"origin\":", joint.parent_body);
    append_transform(out, joint.origin);
    out += ",\"axis\":";
    append_numbers(out, joint.axis);
    out += '}';
  }
  out += "],\"collisions\":[";
  for (std::size_t i = 0; i < robot::kCollisions.size(); ++i) {
    const auto& c = robot::kCollisions[i];
    if (i > 0) out += ',';
    const char* shape = c.shape == model::Shape::box ? "box" : c.shape == model::Shape::cylinder ? "cylinder" : "sphere";
    out += fmt::format("{{\"body\":{},\"shape\":\"{}\",\"size\":", c.body, shape);
    append_numbers(out, c.size_m);
    out += ",\"origin\":";
    append_transform(out, c.origin);
    out += '}';
  }
  const auto frame = [&](int f) {
    const auto& fr = robot::kFrames[static_cast<std::size_t>(f)];
    out += fmt::format("{{\"body\":{},\"placement\":", fr.body);
    append_transform(out, fr.placement);
    out += '}';
  };
  out += "],\"feet\":{\"radius\":";
  append_number(out, kFootRadius_m);
  out += ",\"frames\":[";
  for (int f = 0; f < kFeet; ++f) {
    if (f > 0) out += ',';
    frame(kFootFrames[static_cast<std::size_t>(f)]);
  }
  out += "]},\"hand\":";
  frame(kEeFrame);
  out += '}';
  return out;
}

Run load_run(const std::filesystem::path& path, double rate_hz) {
  if (!(rate_hz > 0.0 && rate_hz <= 1e4)) throw Error(fmt::format("rate {} Hz: must be in (0, 10000]", rate_hz));
  const std::filesystem::path file = std::filesystem::is_directory(path) ? path / "log.csv" : path;
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot read", file.string()));
  std::string header;
  if (!std::getline(in, header) || header.empty()) throw Error(fmt::format("{}: empty, no header", file.string()));
  Csv csv;
  csv.path = file;
  const auto names = split(header);
  csv.width = static_cast<int>(names.size());
  for (int i = 0; i < csv.width; ++i) csv.column[std::string(names[static_cast<std::size_t>(i)])] = i;
  Run run;
  if (names.front() == "time_s") run = load_sim_log(in, csv, rate_hz);
  else if (names.front() == "timestamp") run = load_recorder(in, csv, rate_hz);
  else throw Error(fmt::format("{}: neither a springbok-sim log (time_s, ...) nor a flight-recorder file (timestamp, ...)", file.string()));
  if (run.time_s.empty()) throw Error(fmt::format("{}: no rows", file.string()));
  const std::filesystem::path named = std::filesystem::is_directory(path) ? path : path.parent_path() / path.stem();
  run.title = std::filesystem::absolute(named).lexically_normal().filename().string();
  if (run.title.empty()) run.title = std::filesystem::absolute(named).lexically_normal().parent_path().filename().string();
  return run;
}

std::string run_json(const Run& run) {
  std::string out = "{\"title\":";
  append_string(out, run.title);
  out += ",\"source\":";
  append_string(out, run.source);
  out += ",\"t\":[";
  for (std::size_t i = 0; i < run.time_s.size(); ++i) {
    if (i > 0) out += ',';
    append_number(out, run.time_s[i]);
  }
  out += "],\"series\":{";
  for (std::size_t s = 0; s < run.series.size(); ++s) {
    if (s > 0) out += ',';
    append_string(out, run.series[s].first);
    out += ":[";
    const auto& values = run.series[s].second;
    for (std::size_t i = 0; i < values.size(); ++i) {
      if (i > 0) out += ',';
      append_number(out, values[i]);
    }
    out += ']';
  }
  out += "}}";
  return out;
}

std::string page_html(std::string_view data_script) {
  std::string out =
      "<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
      "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
      "<meta name=\"generator\" content=\"springbok-view\">\n<title>springbok</title>\n</head>\n<body>\n<script>\n";
  out += "window.SPRINGBOK_ROBOT = ";
  out += robot_json();
  out += ";\n";
  out += data_script;
  out += "\n</script>\n<script>\n";
  out += viewer_bundle();
  out += "\n</script>\n</body>\n</html>\n";
  return out;
}

std::filesystem::path default_page_path(const std::filesystem::path& run) {
  if (std::filesystem::is_directory(run)) return run / "view.html";
  std::filesystem::path page = run;
  return page.replace_extension(".html");
}

void write_file(const std::filesystem::path& path, std::string_view text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw Error(fmt::format("{}: cannot write", path.string()));
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  if (!out.flush()) throw Error(fmt::format("{}: write failed", path.string()));
}

}  // namespace springbok::view
