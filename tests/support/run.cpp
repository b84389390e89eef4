#include "support/run.hpp"

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "support/synth.hpp"

namespace moa::test {

std::string read_text(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

RunResult run_moa(const std::string& args) {
  const auto dir = scratch_dir("run");
  const std::string cmd = std::string(MOA_CLI_PATH) + " " + args + " >" + (dir / "out").string() +
                          " 2>" + (dir / "err").string();
  const int status = std::system(cmd.c_str());
  RunResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = read_text(dir / "out");
  r.err = read_text(dir / "err");
  std::filesystem::remove_all(dir);
  return r;
}

BoundedRunResult run_moa_bounded(const std::string& args, const RunLimits& limits) {
  const auto dir = scratch_dir("run");
  const std::string cmd = "exec " + std::string(MOA_CLI_PATH) + " " + args + " >" +
                          (dir / "out").string() + " 2>" + (dir / "err").string();
  const auto start = std::chrono::steady_clock::now();
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::setpgid(0, 0);
    const rlimit fsize{limits.max_file_bytes, limits.max_file_bytes};
    ::setrlimit(RLIMIT_FSIZE, &fsize);
    ::signal(SIGXFSZ, SIG_DFL);
    ::execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  BoundedRunResult r;
  int status = 0;
  rusage usage{};
  const auto deadline = start + std::chrono::duration<double>(limits.seconds);
  while (true) {
    const pid_t done = ::wait4(pid, &status, WNOHANG, &usage);
    if (done == pid) break;
    if (std::chrono::steady_clock::now() >= deadline) {
      r.timed_out = true;
      ::kill(-pid, SIGKILL);
      ::kill(pid, SIGKILL);
      ::wait4(pid, &status, 0, &usage);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  r.max_rss_kb = usage.ru_maxrss;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.file_too_big = WIFSIGNALED(status) && WTERMSIG(status) == SIGXFSZ;
  r.out = read_text(dir / "out");
  r.err = read_text(dir / "err");
  std::filesystem::remove_all(dir);
  return r;
}

std::string limits_exceeded(const BoundedRunResult& r, const RunLimits& limits) {
  std::string what;
  if (r.timed_out) what += "ran longer than " + std::to_string(limits.seconds) + " s; ";
  if (r.max_rss_kb > limits.max_rss_kb) {
    what += "used " + std::to_string(r.max_rss_kb) + " KiB of memory; ";
  }
  if (r.file_too_big)
    what += "wrote a file beyond " + std::to_string(limits.max_file_bytes) + " bytes; ";
  return what;
}

}  // namespace moa::test
