// g6d-bench-soak (bench/soak_main.cc says what it does and how to run it): the service child
// process and /proc.
#include "soak_process.h"

#include <dirent.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <deque>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "proc_stats.h"

namespace g6d::soak {

ServiceProcess::ServiceProcess(const std::vector<std::string>& argv, const std::string& log_path) {
  if (access(argv.at(0).c_str(), X_OK) != 0)
    G6D_THROW("service binary " << argv[0] << " is not executable: " << std::strerror(errno));
  std::vector<char*> args;
  for (const std::string& arg : argv) args.push_back(const_cast<char*>(arg.c_str()));
  args.push_back(nullptr);
  const int log_fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (log_fd < 0)
    G6D_THROW("cannot open the service log " << log_path << ": " << std::strerror(errno));
  const pid_t parent = getpid();
  pid_ = fork();
  if (pid_ < 0) {
    close(log_fd);
    G6D_THROW("fork failed: " << std::strerror(errno));
  }
  if (pid_ == 0) {
    // The child: only async-signal-safe calls until exec.
    setpgid(0, 0);
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) _exit(127);  // the bench died before prctl
    dup2(log_fd, STDOUT_FILENO);          // dup2 clears O_CLOEXEC on the copies
    dup2(log_fd, STDERR_FILENO);
    // Nothing else of the bench's (its LCM sockets and pipes do not set O_CLOEXEC): the
    // service's descriptor count is its own.
    if (syscall(SYS_close_range, 3u, ~0u, 0u) != 0) {
      for (int fd = 3; fd < 1024; ++fd) close(fd);
    }
    execv(args[0], args.data());
    _exit(127);
  }
  close(log_fd);
}

ServiceProcess::~ServiceProcess() {
  if (!exit_.exited && pid_ > 0) {
    kill(pid_, SIGKILL);
    int status = 0;
    waitpid(pid_, &status, 0);
  }
}

bool ServiceProcess::Exited(double now_s) {
  if (exit_.exited) return true;
  int status = 0;
  if (waitpid(pid_, &status, WNOHANG) != pid_) return false;
  Record(status, now_s);
  return true;
}

const ServiceExit& ServiceProcess::Terminate(double timeout_s, double now_s) {
  if (Exited(now_s)) return exit_;
  kill(pid_, SIGTERM);
  const int pidfd = static_cast<int>(syscall(SYS_pidfd_open, pid_, 0));
  if (pidfd >= 0) {
    pollfd fd = {pidfd, POLLIN, 0};
    int ready;
    do {
      ready = poll(&fd, 1, static_cast<int>(timeout_s * 1e3));
    } while (ready < 0 && errno == EINTR);
    close(pidfd);
    if (ready == 0) {
      kill(pid_, SIGKILL);
      exit_.killed_by_us = true;
    }
  }
  // Without pidfd_open (kernel < 5.3) the wait is unbounded; the service bounds its own
  // shutdown (shutdown_timeout_s).
  int status = 0;
  while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
  const bool killed = exit_.killed_by_us;
  Record(status, now_s);
  exit_.killed_by_us = killed;
  return exit_;
}

void ServiceProcess::Record(int status, double now_s) {
  exit_.exited = true;
  exit_.at_s = now_s;
  if (WIFEXITED(status)) exit_.code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) {
    exit_.signal = WTERMSIG(status);
    exit_.core_dumped = WCOREDUMP(status);
  }
}

std::string Tail(const std::string& path, int lines) {
  std::ifstream file(path);
  std::deque<std::string> last;
  std::string line;
  while (std::getline(file, line)) {
    last.push_back(line);
    if (static_cast<int>(last.size()) > lines) last.pop_front();
  }
  std::string out;
  for (const std::string& l : last) out += "    " + l + "\n";
  return out;
}

bool ReadProcess(pid_t pid, Sample* sample) {
  const std::string dir = "/proc/" + std::to_string(pid);
  std::ifstream status(dir + "/status");
  if (!status) return false;
  std::string line;
  bool have_rss = false, have_threads = false;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) {
      sample->rss_mib = std::stod(line.substr(6)) / 1024.0;  // kB
      have_rss = true;
    } else if (line.rfind("Threads:", 0) == 0) {
      sample->threads = std::stoi(line.substr(8));
      have_threads = true;
    }
  }
  // A zombie has neither line.
  if (!have_rss || !have_threads) return false;

  sample->cpu_s = g6d::bench::CpuSeconds(pid);
  if (sample->cpu_s < 0.0) return false;

  DIR* fd_dir = opendir((dir + "/fd").c_str());
  if (fd_dir == nullptr) return false;
  int fds = 0;
  while (const dirent* entry = readdir(fd_dir)) {
    if (std::strcmp(entry->d_name, ".") != 0 && std::strcmp(entry->d_name, "..") != 0) ++fds;
  }
  closedir(fd_dir);
  sample->fds = fds;
  return true;
}

/// Datagrams the kernel dropped on the UDP sockets of `pid` (0 = this process) since they
/// were opened (the "drops" column of /proc/<pid>/net/udp for the process's socket
/// inodes); -1 when it cannot be read. Tells a full socket buffer apart from messages that
/// LCM itself discarded after receiving them.
int64_t UdpDrops(pid_t pid) {
  const std::string dir = "/proc/" + (pid == 0 ? std::string("self") : std::to_string(pid));
  std::vector<std::string> inodes;
  DIR* fd_dir = opendir((dir + "/fd").c_str());
  if (fd_dir == nullptr) return -1;
  while (const dirent* entry = readdir(fd_dir)) {
    char target[256];
    const std::string link = dir + "/fd/" + entry->d_name;
    const ssize_t n = readlink(link.c_str(), target, sizeof(target) - 1);
    if (n <= 0) continue;
    target[n] = '\0';
    if (std::strncmp(target, "socket:[", 8) == 0)
      inodes.emplace_back(target + 8, std::strlen(target + 8) - 1);  // without ']'
  }
  closedir(fd_dir);
  std::ifstream table(dir + "/net/udp");
  if (!table) return -1;
  std::string line;
  std::getline(table, line);  // header
  int64_t drops = 0;
  while (std::getline(table, line)) {
    // sl local rem st tx:rx tr:when retrnsmt uid timeout inode ref pointer drops
    std::istringstream fields(line);
    std::vector<std::string> f;
    for (std::string field; fields >> field;) f.push_back(field);
    if (f.size() < 13) continue;
    if (std::find(inodes.begin(), inodes.end(), f[9]) != inodes.end()) drops += std::stoll(f[12]);
  }
  return drops;
}

}  // namespace g6d::soak
