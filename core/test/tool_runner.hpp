// Runs a built executable of the package in a test: a temporary directory per
// test, and the tool started directly (no shell, so a crash shows up as a
// signal in the status rather than as a shell's exit code 128 + n), with its
// stdout and stderr captured.
#pragma once

#include <gtest/gtest.h>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

extern char** environ;

namespace bdis_test {

struct RunResult {
  int status = -1;  // raw waitpid status
  std::string out, err;
  bool exited() const { return WIFEXITED(status); }
  int code() const { return WIFEXITED(status) ? WEXITSTATUS(status) : -1; }
  std::string all() const { return out + err; }
};

inline std::string readFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

/// The folder of the built tools: $BDIS_TOOLS_DIR, else the folder of this
/// test executable (the build puts the tools and the tests side by side).
inline std::string toolsDir() {
  if (const char* env = std::getenv("BDIS_TOOLS_DIR"); env && *env) return env;
  std::error_code ec;
  return std::filesystem::read_symlink("/proc/self/exe", ec).parent_path().string();
}

/// Fixture for one tool in toolsDir(); subclasses pass its name.
class ToolTest : public ::testing::Test {
 protected:
  explicit ToolTest(std::string tool_name) : tool_name_(std::move(tool_name)) {}

  void SetUp() override {
    tool_ = toolsDir() + "/" + tool_name_;
    ASSERT_TRUE(std::filesystem::exists(tool_)) << tool_ << " is not built";
    std::string tmpl =
        (std::filesystem::temp_directory_path() / (tool_name_ + "_test_XXXXXX")).string();
    ASSERT_NE(mkdtemp(tmpl.data()), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override {
    std::error_code ec;
    if (!dir_.empty()) std::filesystem::remove_all(dir_, ec);
  }

  std::string path(const std::string& name) const {
    return (std::filesystem::path(dir_) / name).string();
  }

  RunResult run(const std::vector<std::string>& args) {
    const std::string out_path = path(".stdout"), err_path = path(".stderr");
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    std::vector<std::string> argv_s = {tool_};
    argv_s.insert(argv_s.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (std::string& a : argv_s) argv.push_back(a.data());
    argv.push_back(nullptr);
    RunResult r;
    pid_t pid = 0;
    const int rc = posix_spawn(&pid, tool_.c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    EXPECT_EQ(rc, 0) << "cannot start " << tool_;
    if (rc != 0) return r;
    EXPECT_EQ(waitpid(pid, &r.status, 0), pid);
    r.out = readFile(out_path);
    r.err = readFile(err_path);
    return r;
  }

  std::string tool_name_, tool_, dir_;
};

}  // namespace bdis_test
