#pragma once
/// @file soak_process.h
/// g6d-bench-soak's service under test: g6d-service as a child process, how it ended, and
/// what /proc says about it once a second (memory, threads, descriptors, CPU, UDP drops).

#include <sys/types.h>

#include <cstdint>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

namespace g6d::soak {

/// How the service process ended.
struct ServiceExit {
  bool exited = false;        ///< it has ended (reaped)
  int code = -1;              ///< exit code when it exited normally
  int signal = 0;             ///< the signal that killed it, else 0
  bool core_dumped = false;   ///< the kernel wrote a core dump
  bool killed_by_us = false;  ///< SIGKILL after it ignored SIGTERM for exit_timeout_s
  double at_s = -1.0;         ///< when it was seen gone, seconds after the load started

  bool Clean() const { return exited && signal == 0 && code == 0 && !killed_by_us; }
  std::string Describe() const {
    if (!exited) return "still running";
    std::ostringstream out;
    if (signal != 0) {
      out << "killed by signal " << signal << " (" << strsignal(signal) << ")"
          << (core_dumped ? ", core dumped" : "");
    } else {
      out << "exit code " << code << (code == 127 ? " (exec failed?)" : "");
    }
    if (killed_by_us) out << " after ignoring SIGTERM (SIGKILL sent)";
    return out.str();
  }
};

/// g6d-service as a child process (fork + exec) with stdout and stderr in a log file, in a
/// process group of its own (a Ctrl-C at the terminal reaches the bench only, which then
/// stops the service with SIGTERM) and with SIGTERM as its parent-death signal (a killed
/// bench leaves no service behind). SIGKILLed and reaped on destruction if still running.
class ServiceProcess {
 public:
  /// Starts `argv` (argv[0] the executable); throws g6d::Error when it is not executable,
  /// the log cannot be opened or fork fails.
  ServiceProcess(const std::vector<std::string>& argv, const std::string& log_path);
  ~ServiceProcess();
  ServiceProcess(const ServiceProcess&) = delete;
  ServiceProcess& operator=(const ServiceProcess&) = delete;

  pid_t pid() const { return pid_; }
  const ServiceExit& exit_info() const { return exit_; }

  /// True once the process has ended (non-blocking; reaps it and records how).
  bool Exited(double now_s);

  /// SIGTERM, then waits up to `timeout_s` for the exit (on a pidfd, no polling loop);
  /// SIGKILL past that. Returns how it ended.
  const ServiceExit& Terminate(double timeout_s, double now_s);

 private:
  void Record(int status, double now_s);

  pid_t pid_ = -1;
  ServiceExit exit_;
};

/// The last `lines` lines of a text file, each indented by four spaces.
std::string Tail(const std::string& path, int lines);

/// One once-a-second look at the service process and the run.
struct Sample {
  double t_s = 0.0;      ///< seconds since the load started
  double rss_mib = 0.0;  ///< VmRSS, MiB
  int threads = 0;       ///< Threads
  int fds = 0;           ///< entries of /proc/<pid>/fd
  double cpu_s = 0.0;    ///< user + system CPU time, seconds
  int64_t sent = 0;      ///< messages published so far
  int64_t answered = 0;  ///< answers matched to them so far
  int64_t dropped = 0;   ///< frames_dropped of the last status
};

/// Reads RSS, threads, descriptors and CPU of `pid` into `sample`; false when the process
/// is gone.
bool ReadProcess(pid_t pid, Sample* sample);

/// Datagrams the kernel dropped on the UDP sockets of `pid` (0 = this process) since they
/// were opened (the "drops" column of /proc/<pid>/net/udp for the process's socket
/// inodes); -1 when it cannot be read. Tells a full socket buffer apart from messages that
/// LCM itself discarded after receiving them.
int64_t UdpDrops(pid_t pid);

}  // namespace g6d::soak
