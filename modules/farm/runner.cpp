// Running tasks as child processes: one task (`weft farm task`, what a Slurm array task runs)
// and the local runner (`--farm local -j N`), which share start_task, so a task behaves the
// same under both: stale temporaries removed, output appended to CACHE/logs/<id>.log.
module;
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <deque>
#include <expected>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>
module weft.farm;
import weft.core;

namespace weft::farm {

namespace {

// write_file_atomically's temporaries of `file`: "<name>.<pid>-<n>.tmp" in the same folder.
void remove_stale_temporaries(const std::filesystem::path& file) {
  std::error_code ec;
  const auto dir = file.parent_path();
  const std::string prefix = file.filename().string() + ".";
  for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.size() > prefix.size() + 4 && name.starts_with(prefix) && name.ends_with(".tmp")) {
      std::error_code ignored;
      std::filesystem::remove(it->path(), ignored);
    }
  }
}

std::vector<char*> argv_of(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  return argv;
}

}  // namespace

Result<int> start_task(const TaskList& list, std::size_t index) {
  if (index >= list.tasks.size())
    return fail(ErrorKind::InvalidArgument, "task {} is not in the list (it has {} tasks: 0 to {})", index,
                list.tasks.size(), list.tasks.size() ? list.tasks.size() - 1 : 0);
  const Task& task = list.tasks[index];
  std::error_code ec;
  for (const auto& o : task.outputs) {
    const auto file = output_path(list, o);
    std::filesystem::create_directories(file.parent_path(), ec);
    if (ec) return fail(ErrorKind::Io, "cannot create '{}': {}", file.parent_path().string(), ec.message());
    remove_stale_temporaries(file);
  }
  const auto log = log_path(list, task);
  std::filesystem::create_directories(log.parent_path(), ec);
  if (ec) return fail(ErrorKind::Io, "cannot create '{}': {}", log.parent_path().string(), ec.message());
  const int log_fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (log_fd < 0) return fail(ErrorKind::Io, "cannot write the log '{}': {}", log.string(), std::strerror(errno));
  std::string header = "[weft farm] task " + task.id + " (" + task.label + "):";
  for (const auto& a : task.command) header += " " + a;
  header += "\n";
  (void)!::write(log_fd, header.data(), header.size());
  auto argv = argv_of(task.command);
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(log_fd);
    return fail(ErrorKind::Io, "cannot start task {}: fork: {}", task.id, std::strerror(errno));
  }
  if (pid == 0) {
    const int null_fd = ::open("/dev/null", O_RDONLY);
    if (null_fd >= 0) ::dup2(null_fd, 0);
    ::dup2(log_fd, 1);
    ::dup2(log_fd, 2);
    ::execvp(argv[0], argv.data());
    std::fprintf(stderr, "[weft farm] cannot run '%s': %s\n", argv[0], std::strerror(errno));
    ::_exit(127);
  }
  ::close(log_fd);
  return int(pid);
}

int wait_task(int pid) {
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return 1;
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 1;
}

Result<TaskRun> run_task(const TaskList& list, std::size_t index) {
  if (index < list.tasks.size() && is_done(list, list.tasks[index])) return TaskRun{0, true};
  auto pid = start_task(list, index);
  if (!pid) return std::unexpected(pid.error());
  int code = wait_task(*pid);
  if (code == 0 && !is_done(list, list.tasks[index])) code = 1;
  return TaskRun{code, false};
}

Result<LocalRun> run_local(const TaskList& list, unsigned jobs) {
  if (jobs == 0) jobs = 1;
  LocalRun run;
  std::deque<std::size_t> queue;
  for (std::size_t i = 0; i < list.tasks.size(); ++i) {
    if (is_done(list, list.tasks[i])) ++run.skipped;
    else queue.push_back(i);
  }
  if (run.skipped)
    log::info(weft::format("farm: {} of {} tasks already in the cache '{}'", run.skipped, list.tasks.size(),
                           list.cache.string()));
  std::map<int, std::size_t> running;  // pid -> task
  const std::size_t total = queue.size();
  const auto start = std::chrono::steady_clock::now();
  std::size_t finished = 0;
  while (!queue.empty() || !running.empty()) {
    while (!queue.empty() && running.size() < jobs) {
      const std::size_t i = queue.front();
      queue.pop_front();
      auto pid = start_task(list, i);
      if (!pid) {
        for (const auto& [p, t] : running) ::kill(p, SIGTERM);
        for (const auto& [p, t] : running) wait_task(p);
        return std::unexpected(pid.error());
      }
      running[*pid] = i;
    }
    int status = 0;
    const pid_t pid = ::waitpid(-1, &status, 0);
    if (pid < 0) {
      if (errno == EINTR) continue;
      break;
    }
    const auto it = running.find(pid);
    if (it == running.end()) continue;
    const std::size_t i = it->second;
    running.erase(it);
    int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
    if (code == 0 && !is_done(list, list.tasks[i])) code = 1;
    ++finished;
    ++run.ran;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (code != 0) {
      run.failed.push_back(i);
      log::warn(weft::format("farm: task '{}' failed (exit {}); log {}: {}", list.tasks[i].label, code,
                             log_path(list, list.tasks[i]).string(), last_log_line(list, list.tasks[i])));
    } else {
      log::info(weft::format("[{}/{}] {} ({:.0f} s; ETA {:.0f} s)", finished, total, list.tasks[i].label, elapsed,
                             elapsed / double(finished) * double(total - finished)));
    }
  }
  std::sort(run.failed.begin(), run.failed.end());  // in list order, however they finished
  return run;
}

Result<int> run_command(const std::vector<std::string>& args) {
  if (args.empty()) return fail(ErrorKind::InvalidArgument, "an empty command");
  auto argv = argv_of(args);
  const pid_t pid = ::fork();
  if (pid < 0) return fail(ErrorKind::Io, "cannot run '{}': fork: {}", args[0], std::strerror(errno));
  if (pid == 0) {
    ::execvp(argv[0], argv.data());
    std::fprintf(stderr, "weft farm: cannot run '%s': %s\n", argv[0], std::strerror(errno));
    ::_exit(127);
  }
  return wait_task(int(pid));
}

}  // namespace weft::farm
