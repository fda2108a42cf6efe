// Helpers for end-to-end tests that run the project's programs.
#pragma once

#include <doctest/doctest.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

namespace implicit_test {

struct command_result {
  int         status = -1;
  std::string output = "";  // stdout and stderr together
};

// Run a shell command, collecting its output.
inline command_result run_command(const std::string& command) {
  auto result = command_result{};
  auto pipe   = popen((command + " 2>&1").c_str(), "r");
  REQUIRE(pipe != nullptr);
  char buffer[4096];
  while (auto n = fread(buffer, 1, sizeof(buffer), pipe))
    result.output.append(buffer, n);
  auto status   = pclose(pipe);
  result.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

// Path of one of the project's programs in the build directory.
inline std::string program_path(const std::string& name) {
  return std::string{IMPLICIT_BINARY_DIR} + "/" + name;
}

inline std::string example_scene(
    const std::string& name = "sdfunction/sdfunction.json") {
  return std::string{IMPLICIT_SOURCE_DIR} + "/examples/" + name;
}

// A fresh directory for one test's files.
inline std::filesystem::path test_dir(const std::string& name) {
  auto dir = std::filesystem::path{IMPLICIT_BINARY_DIR} / "test_outputs" / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace implicit_test
