#pragma once
/// @file proc_stats.h
/// What /proc says of a process, for the service benchmarks: CPU time and resident memory.

#include <sys/types.h>
#include <unistd.h>

#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

namespace g6d::bench {

/// "/proc/<pid>" ("/proc/self" for pid 0).
inline std::string ProcDir(pid_t pid) {
  return "/proc/" + (pid == 0 ? std::string("self") : std::to_string(pid));
}

/// CPU seconds (user + system) of `pid` (0 = this process); -1 when /proc has no such process.
inline double CpuSeconds(pid_t pid) {
  std::ifstream file(ProcDir(pid) + "/stat");
  const std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  // Fields after the command name (which may contain spaces) start after the last ')'.
  const size_t close = text.rfind(')');
  if (close == std::string::npos) return -1.0;
  std::istringstream fields(text.substr(close + 2));
  std::string field;
  double utime = 0.0, stime = 0.0;
  for (int i = 3; i <= 15 && fields >> field; ++i) {
    if (i == 14) utime = std::stod(field);
    if (i == 15) stime = std::stod(field);
  }
  return (utime + stime) / static_cast<double>(sysconf(_SC_CLK_TCK));
}

/// Resident set size of `pid` (0 = this process), MiB; 0 when unknown (e.g. a zombie).
inline double RssMiB(pid_t pid) {
  std::ifstream file(ProcDir(pid) + "/status");
  std::string line;
  while (std::getline(file, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  }
  return 0.0;
}

}  // namespace g6d::bench
