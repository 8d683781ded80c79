// Runs a command line for the CLI tests: exit code and stdout+stderr together.
#pragma once
#include <array>
#include <cstdio>
#include <string>
#include <sys/wait.h>

namespace weft::test {

struct CommandRun {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

inline CommandRun run_command(const std::string& command) {
  CommandRun r;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buffer{};
  while (std::fgets(buffer.data(), buffer.size(), pipe)) r.output += buffer.data();
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

}  // namespace weft::test
