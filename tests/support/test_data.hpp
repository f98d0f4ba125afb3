// The tests' data files (tests/data/README.md): those kept in the repository, then those of
// the same kind in ../shared that the repository does not hold (a held-out set dropped there
// is picked up), then those of an extra folder named by an environment variable. Sorted by
// file name; a name in the repository hides the same name elsewhere.
#pragma once

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace springbok::test {

// The repository's test data folder (tests/data).
inline std::filesystem::path data_dir() { return std::filesystem::path(SPRINGBOK_SOURCE_DIR) / "tests" / "data"; }

// Files named <prefix>*<extension> in tests/data/`repo_subdir`, then in
// ../shared/`shared_subdir`, then in $`env_dir` (when set and non-empty).
inline std::vector<std::string> data_files(const std::string& repo_subdir, const std::string& shared_subdir,
                                           const std::string& prefix, const std::string& extension,
                                           const char* env_dir = nullptr) {
  namespace fs = std::filesystem;
  std::vector<fs::path> dirs{data_dir() / repo_subdir, fs::path(SPRINGBOK_SHARED_DIR) / shared_subdir};
  if (env_dir != nullptr) {
    if (const char* extra = std::getenv(env_dir); extra != nullptr && *extra != '\0') dirs.emplace_back(extra);
  }
  std::map<std::string, std::string> by_name;
  for (const fs::path& dir : dirs) {
    if (!fs::is_directory(dir)) continue;
    for (const auto& entry : fs::directory_iterator(dir)) {
      const std::string name = entry.path().filename().string();
      if (name.rfind(prefix, 0) == 0 && entry.path().extension() == extension) by_name.emplace(name, entry.path().string());
    }
  }
  std::vector<std::string> files;
  for (const auto& [name, path] : by_name) files.push_back(path);
  return files;
}

// The dynamics oracle's states of the robot this build is for (tests/data/reference/<robot>,
// ../shared/robot/<robot>/reference or, for the first robot, ../shared/robot/reference,
// $SPRINGBOK_REFERENCE_DIR).
inline std::vector<std::string> reference_state_files(std::string_view robot_name) {
  const std::string robot(robot_name);
  const bool own_folder = std::filesystem::is_directory(std::filesystem::path(SPRINGBOK_SHARED_DIR) / "robot" / robot);
  return data_files("reference/" + robot, own_folder ? "robot/" + robot + "/reference" : "robot/reference", "state_",
                    ".txt", "SPRINGBOK_REFERENCE_DIR");
}

// The QP instances (tests/data/qp, ../shared/qp/instances).
inline std::vector<std::string> qp_instance_files() { return data_files("qp", "qp/instances", "", ".qp"); }

// One QP instance of the repository's set by file name.
inline std::string qp_instance(const std::string& file) { return (data_dir() / "qp" / file).string(); }

}  // namespace springbok::test
