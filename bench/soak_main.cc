// g6d-bench-soak: soak benchmark of the g6d-service binary (not a unit test).
//
// Starts the real g6d-service as a child process on a private udpm bus (ttl=0, a port of
// its own), publishes a fixed-rate mix of good frames (an LCM log of g6d_rgbd_frame_t,
// cycled, each with a fresh seq and utime) and bad frames (every kind of
// tests/bad_frames.h, cycled) for a long time, and watches both the answers and the
// process:
//  - every answer is matched to the frame it answers (by seq; the two kinds that are not
//    our message type at all are answered with seq -1 and matched in send order);
//  - the service's status (frames received / processed / dropped / stale / rejected)
//    accounts for the frames without an answer: by design at 30 Hz most good frames are
//    replaced in the latest-frame mailbox while the previous one is solved;
//  - every second: VmRSS, Threads, open file descriptors and CPU time of the service from
//    /proc/<pid>, and whether it is still alive (waitpid WNOHANG).
// At the end the service gets SIGTERM and must exit with code 0. The run passes when the
// service never died, exited cleanly, its resident memory grew less than
// --max-rss-growth-pct from the reference time (1 min; 20% of the run when it is shorter
// than 2 min) to the end, its threads and descriptors were constant after the reference
// time, every bad frame was answered with an error (or, for the kinds that pass validation
// and only fail per instance, dropped in the mailbox like any frame), no good frame was
// rejected and no frame is unaccounted for; with --withhold-every N (every Nth good frame's
// seq skipped, nothing sent) the service's frames_lost must equal the seq gaps it was
// given (plus at most the frames the kernel dropped).
//
//   g6d-bench-soak --templates out/soak/sample/caches --log out/soak/sample/sample.lcmlog
//       [--duration-s 600] [--rate-hz 30] [--bad-every 2] [--withhold-every N]
//       [--service-bin build/service/g6d-service]
//       [--service-log service.log] [--summary-json F] [--samples-csv F] [--plot F.png]
//
// Exit code: 0 pass, 1 a criterion failed (the summary says which), 2 the run could not be
// set up (bad options, unreadable log, service binary missing or never ready).
#include <dirent.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/eventfd.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <deque>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/error.h"
#include "g6d/pose_array_t.hpp"
#include "g6d/service_status_t.hpp"
#include "proc_stats.h"
#include "replay/frame_log.h"
#include "replay/replay.h"
#include "wire/bad_frames.h"
#include "wire/lcm_loop.h"

namespace {

using Clock = std::chrono::steady_clock;
using g6d::synthetic::BadCase;

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

int64_t NowUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Set by SIGINT/SIGTERM: the load phase ends early, the service is stopped and the
// summary is still written (a bench executable, not lib/: the one global is the signal flag).
volatile std::sig_atomic_t g_interrupted = 0;
void OnInterrupt(int) { g_interrupted = 1; }

// ---- Options -------------------------------------------------------------------------------

/// Everything the soak can be told.
struct SoakOptions {
  std::string service_bin;               ///< g6d-service executable
  std::string templates_dir;             ///< --templates of the service (template caches)
  std::string log_path;                  ///< LCM log of g6d_rgbd_frame_t: the good frames, cycled
  std::string log_channel = "G6D_RGBD";  ///< frame channel inside the log
  /// LCM URL of the private bus; empty = udpm on a port derived from this process's pid,
  /// ttl=0, 4 MB receive buffer.
  std::string lcm_url;
  std::string input_channel = "G6D_RGBD";     ///< frames to the service
  std::string output_channel = "G6D_POSES";   ///< its answers
  std::string status_channel = "G6D_STATUS";  ///< its status
  double duration_s = 600.0;                  ///< length of the load phase, seconds
  double rate_hz = 30.0;                      ///< messages per second (good and bad together)
  int bad_every = 2;                          ///< every Nth message is bad (0 = none, 1 = all)
  /// Every Nth good frame is withheld: its seq is skipped, nothing is sent, and the
  /// service must count it lost (frames_lost); 0 = none.
  int withhold_every = 0;
  int workers = 2;                            ///< --workers of the service
  int hypotheses = 0;  ///< --hypotheses K of the service; 0 = the service's default
  std::vector<std::string> service_args;    ///< more arguments for the service, as given
  double max_rss_growth_pct = 5.0;          ///< pass limit of RSS growth, reference -> end, percent
  double startup_timeout_s = 120.0;         ///< wait for the service's first status, seconds
  double drain_timeout_s = 60.0;            ///< wait for the last answers after the load, seconds
  double exit_timeout_s = 30.0;             ///< wait for exit after SIGTERM before SIGKILL, seconds
  double progress_s = 30.0;                 ///< period of the progress lines, seconds
  std::string service_log = "service.log";  ///< the service's stdout and stderr
  std::string summary_json;                 ///< summary file (empty = none)
  std::string samples_csv;                  ///< one row per second (empty = none)
  std::string plot_png;                     ///< RSS / threads / fds plot (empty = none)

  /// Empty when valid, else names the bad field.
  std::string Check() const {
    if (service_bin.empty()) return "--service-bin is empty";
    if (templates_dir.empty()) return "--templates is required";
    if (log_path.empty()) return "--log is required";
    if (!(duration_s > 0.0)) return "--duration-s must be > 0";
    if (!(rate_hz > 0.0) || rate_hz > 1000.0) return "--rate-hz must be in (0, 1000]";
    if (bad_every < 0) return "--bad-every must be >= 0";
    if (withhold_every < 0) return "--withhold-every must be >= 0";
    if (workers < 1) return "--workers must be >= 1";
    if (hypotheses < 0) return "--hypotheses must be >= 0";
    if (!(max_rss_growth_pct >= 0.0)) return "--max-rss-growth-pct must be >= 0";
    if (!(startup_timeout_s > 0.0)) return "--startup-timeout-s must be > 0";
    if (!(drain_timeout_s >= 0.0)) return "--drain-timeout-s must be >= 0";
    if (!(exit_timeout_s > 0.0)) return "--exit-timeout-s must be > 0";
    if (!(progress_s > 0.0)) return "--progress-s must be > 0";
    if (service_log.empty()) return "--service-log is empty";
    return {};
  }

  /// Seconds after the start of the load from which memory growth is measured and threads
  /// and descriptors must stay constant: 1 min, or 20% of a run shorter than 2 min.
  double ReferenceTime() const { return duration_s >= 120.0 ? 60.0 : 0.2 * duration_s; }
};

// ---- The service process -------------------------------------------------------------------

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
  ServiceProcess(const std::vector<std::string>& argv, const std::string& log_path) {
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
  ~ServiceProcess() {
    if (!exit_.exited && pid_ > 0) {
      kill(pid_, SIGKILL);
      int status = 0;
      waitpid(pid_, &status, 0);
    }
  }
  ServiceProcess(const ServiceProcess&) = delete;
  ServiceProcess& operator=(const ServiceProcess&) = delete;

  pid_t pid() const { return pid_; }
  const ServiceExit& exit_info() const { return exit_; }

  /// True once the process has ended (non-blocking; reaps it and records how).
  bool Exited(double now_s) {
    if (exit_.exited) return true;
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) != pid_) return false;
    Record(status, now_s);
    return true;
  }

  /// SIGTERM, then waits up to `timeout_s` for the exit (on a pidfd, no polling loop);
  /// SIGKILL past that. Returns how it ended.
  const ServiceExit& Terminate(double timeout_s, double now_s) {
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

 private:
  void Record(int status, double now_s) {
    exit_.exited = true;
    exit_.at_s = now_s;
    if (WIFEXITED(status)) exit_.code = WEXITSTATUS(status);
    if (WIFSIGNALED(status)) {
      exit_.signal = WTERMSIG(status);
      exit_.core_dumped = WCOREDUMP(status);
    }
  }

  pid_t pid_ = -1;
  ServiceExit exit_;
};

/// The last `lines` lines of a text file.
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

// ---- /proc ---------------------------------------------------------------------------------

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

// ---- LCM -----------------------------------------------------------------------------------

using g6d::LcmHandleThread;

// ---- Answers -------------------------------------------------------------------------------

/// What happened to the messages of one bad kind.
struct KindCounts {
  int64_t sent = 0;
  int64_t answered = 0;
  int64_t expected = 0;     ///< answered with the expected status and words
  int64_t other_error = 0;  ///< answered with an error, but not the expected one
  int64_t not_error = 0;    ///< answered with a pose: a bad frame taken for a good one
  std::string example;      ///< the message of the first unexpected answer
};

/// Counts of the good frames.
struct GoodCounts {
  int64_t sent = 0;
  int64_t answered = 0;
  int64_t frame_ok = 0;                      ///< answered STATUS_OK
  int64_t rejected = 0;                      ///< answered STATUS_BAD_FRAME: a good frame refused
  std::string example;                       ///< the message of the first rejection
  std::map<std::string, int64_t> estimates;  ///< estimates of the answers per status name
};

/// Everything the collector knows, copied out under its lock.
struct Tally {
  GoodCounts good;
  std::vector<KindCounts> kinds;        ///< per bad case
  int64_t answers = 0;                  ///< answers on the output channel, all of them
  int64_t unmatched = 0;                ///< answers to no message of this run
  int64_t duplicates = 0;               ///< second answers to a message
  std::vector<double> good_latency_s;   ///< publish -> answer of good frames
  std::vector<double> good_service_s;   ///< total_s of their answers
  std::vector<double> error_latency_s;  ///< publish -> answer of bad frames
  /// The "decode" timing of every answer: the service's LCM handler time for the message
  /// (LCM drops new messages while its subscription queue is full, so this bounds how
  /// far the handler can fall behind).
  std::vector<double> decode_s;
  bool has_status = false;
  g6d::service_status_t status{};  ///< the last one
};

/// Matches answers on the output channel to the messages sent and keeps the service's
/// last status; called from the LCM pump thread and the publishing thread.
class AnswerCollector {
 public:
  explicit AnswerCollector(const std::vector<BadCase>* cases) : cases_(cases) {
    tally_.kinds.resize(cases->size());
  }

  /// Records that message `seq` was withheld (never sent): its seq is a gap for the service.
  void Withheld(int64_t seq) {
    std::lock_guard<std::mutex> lock(mutex_);
    G6D_CHECK(seq == static_cast<int64_t>(messages_.size()) + 1);
    messages_.push_back({kWithheld, Clock::now(), false});
  }

  /// Records message `seq` (= 1, 2, ... in send order) of kind `kind` (-1 = good).
  void Sent(int64_t seq, int kind, Clock::time_point at) {
    std::lock_guard<std::mutex> lock(mutex_);
    G6D_CHECK(seq == static_cast<int64_t>(messages_.size()) + 1);
    messages_.push_back({kind, at, false});
    if (kind < 0) {
      ++tally_.good.sent;
    } else {
      ++tally_.kinds[kind].sent;
      if (!(*cases_)[kind].seq_known) unnamed_.push_back(seq);
    }
  }

  void OnAnswer(const lcm::ReceiveBuffer*, const std::string&, const g6d::pose_array_t* answer) {
    const Clock::time_point now = Clock::now();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++tally_.answers;
      for (size_t i = 0; i < answer->timing_names.size() && i < answer->timing_s.size(); ++i) {
        if (answer->timing_names[i] == "decode") tally_.decode_s.push_back(answer->timing_s[i]);
      }
      int64_t seq = answer->seq;
      if (seq == -1 && !unnamed_.empty()) {
        // Not our message type: the service cannot read the seq. It answers these at once
        // from its LCM thread, in arrival order, so they go to the oldest such message.
        seq = unnamed_.front();
        unnamed_.pop_front();
      }
      if (seq < 1 || seq > static_cast<int64_t>(messages_.size()) ||
          messages_[seq - 1].kind == kWithheld) {
        ++tally_.unmatched;
      } else if (messages_[seq - 1].answered) {
        ++tally_.duplicates;
      } else {
        messages_[seq - 1].answered = true;
        ++answered_;
        Evaluate(messages_[seq - 1], *answer, Seconds(now - messages_[seq - 1].sent));
      }
    }
    changed_.notify_all();
  }

  void OnStatus(const lcm::ReceiveBuffer*, const std::string&,
                const g6d::service_status_t* status) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      tally_.status = *status;
      tally_.has_status = true;
    }
    changed_.notify_all();
  }

  int64_t answered() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return answered_;
  }

  Tally Snapshot() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return tally_;
  }

  /// Waits up to `timeout` for a status published at or after `utime`; true when one came.
  bool WaitForStatusSince(int64_t utime, Clock::duration timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, timeout,
                             [&] { return tally_.has_status && tally_.status.utime >= utime; });
  }

  /// Waits up to `timeout` until the service is idle in a status published at or after
  /// `utime` (nothing being solved or waiting in the mailbox) and every answer it
  /// published has arrived here; true when that happened.
  bool WaitForDrain(int64_t utime, Clock::duration timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, timeout, [&] {
      const g6d::service_status_t& s = tally_.status;
      return tally_.has_status && s.utime >= utime && s.busy == 0 && s.mailbox_full == 0 &&
             tally_.answers >= s.frames_processed + s.frames_rejected;
    });
  }

 private:
  static constexpr int kWithheld = -2;
  struct Message {
    int kind = -1;  ///< -1 good, kWithheld, else index into cases_
    Clock::time_point sent;
    bool answered = false;
  };

  void Evaluate(const Message& message, const g6d::pose_array_t& answer, double latency_s) {
    const bool frame_ok = answer.status == g6d::pose_array_t::STATUS_OK;
    if (message.kind < 0) {
      GoodCounts& good = tally_.good;
      ++good.answered;
      if (frame_ok) {
        ++good.frame_ok;
        for (const g6d::pose_estimate_t& estimate : answer.estimates)
          ++good.estimates[g6d::EstimateStatusName(estimate.status)];
        tally_.good_latency_s.push_back(latency_s);
        tally_.good_service_s.push_back(answer.total_s);
      } else {
        if (good.rejected++ == 0) good.example = answer.message;
      }
      return;
    }
    const BadCase& bad = (*cases_)[message.kind];
    KindCounts& counts = tally_.kinds[message.kind];
    ++counts.answered;
    tally_.error_latency_s.push_back(latency_s);
    // An error answer: the frame refused, or every estimate failed. The message shown for
    // an unexpected answer is the frame's, or that of the first unexpected estimate.
    bool all_failed = !answer.estimates.empty(), all_expected = !answer.estimates.empty();
    std::string message_text = answer.message;
    for (const g6d::pose_estimate_t& estimate : answer.estimates) {
      const bool as_expected = estimate.status == bad.estimate_status &&
                               estimate.message.find(bad.words) != std::string::npos;
      if (frame_ok && all_expected && !as_expected) message_text = estimate.message;
      all_failed = all_failed && estimate.status != g6d::pose_estimate_t::STATUS_OK;
      all_expected = all_expected && as_expected;
    }
    const bool is_error = !frame_ok || all_failed;
    const bool expected =
        answer.status == bad.frame_status &&
        (frame_ok ? all_expected : answer.message.find(bad.words) != std::string::npos);
    if (expected) {
      ++counts.expected;
    } else {
      if (counts.other_error + counts.not_error == 0) counts.example = message_text;
      ++(is_error ? counts.other_error : counts.not_error);
    }
  }

  const std::vector<BadCase>* cases_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<Message> messages_;  ///< index seq - 1
  std::deque<int64_t> unnamed_;    ///< unanswered messages the service answers with seq -1
  int64_t answered_ = 0;
  Tally tally_;
};

// ---- Report --------------------------------------------------------------------------------

/// The verdict and the numbers behind it.
struct SoakReport {
  bool success = false;
  std::vector<std::string> failures;  ///< one line per failed criterion
  std::vector<std::string> notes;     ///< things worth a look that do not fail the run
  double wall_s = 0.0;                ///< load phase
  int64_t sent = 0, publish_failures = 0;
  bool interrupted = false, drained = false;
  ServiceExit exit;
  bool crashed = false;  ///< died before the end of the load (or the drain)
  Tally tally;
  bool final_status = false;  ///< the status published at shutdown arrived
  // Accounting (from the service's last status).
  int64_t received = 0, processed = 0, dropped = 0, stale = 0, rejected = 0;
  int64_t answered = 0;         ///< answers matched to sent messages
  int64_t lost = 0;             ///< sent - answered - dropped - stale
  int64_t not_received = 0;     ///< sent - received: lost before the service
  int64_t unaccounted = 0;      ///< received - (processed + rejected) - dropped - stale
  int64_t answers_missing = 0;  ///< (processed + rejected) - answers: lost on the way back
  int64_t frame_error_sent = 0, frame_error_unanswered = 0;
  /// Kernel drops on the UDP sockets of the service and of the bench (-1 = unknown).
  int64_t service_udp_drops = -1, bench_udp_drops = -1;
  int64_t mailbox_sent = 0, mailbox_unanswered = 0;  ///< good + instance-error frames
  // Seq gaps (--withhold-every): good frames withheld, and the gaps the service should see:
  // withheld frames and bad messages it cannot read a seq from, each before a later
  // message it can (the service counts no gap before its first frame or after its last).
  int64_t withheld = 0, expected_gaps = 0;
  int64_t service_lost = 0, service_out_of_order = 0;  ///< from the service's last status
  // Process.
  double reference_s = 0.0;  ///< where the growth is measured from
  Sample reference, end;
  double rss_growth_pct = 0.0, rss_max_mib = 0.0;
  int threads_min = 0, threads_max = 0, fds_min = 0, fds_max = 0;
  double cpu_cores = 0.0, cpu_cores_after_reference = 0.0;
};

std::string Ordinal(int n) {
  if (n % 100 >= 11 && n % 100 <= 13) return std::to_string(n) + "th";
  const char* suffix[] = {"th", "st", "nd", "rd"};
  return std::to_string(n) + (n % 10 <= 3 ? suffix[n % 10] : "th");
}

void Evaluate(const SoakOptions& options, const std::vector<BadCase>& cases,
              const std::vector<Sample>& samples, SoakReport* report) {
  const Tally& t = report->tally;
  if (t.has_status) {
    report->received = t.status.frames_received;
    report->processed = t.status.frames_processed;
    report->dropped = t.status.frames_dropped;
    report->stale = t.status.frames_stale;
    report->rejected = t.status.frames_rejected;
  }
  report->answered = t.good.answered;
  for (const KindCounts& k : t.kinds) report->answered += k.answered;
  report->service_lost = t.status.frames_lost;
  report->service_out_of_order = t.status.frames_out_of_order;
  report->lost = report->sent - report->answered - report->dropped - report->stale;
  report->not_received = report->sent - report->received;
  report->unaccounted =
      report->received - report->processed - report->rejected - report->dropped - report->stale;
  report->answers_missing = report->processed + report->rejected - t.answers;
  report->mailbox_sent = t.good.sent;
  report->mailbox_unanswered = t.good.sent - t.good.answered;
  for (size_t c = 0; c < cases.size(); ++c) {
    const KindCounts& k = t.kinds[c];
    if (cases[c].InstanceError()) {
      report->mailbox_sent += k.sent;
      report->mailbox_unanswered += k.sent - k.answered;
    } else {
      report->frame_error_sent += k.sent;
      report->frame_error_unanswered += k.sent - k.answered;
    }
  }

  // Process samples of the load phase: reference (first at or after reference_s) and end.
  report->reference_s = options.ReferenceTime();
  if (!samples.empty()) {
    report->end = samples.back();
    report->reference = samples.back();
    for (const Sample& s : samples) {
      if (s.t_s >= report->reference_s) {
        report->reference = s;
        break;
      }
    }
    report->threads_min = report->threads_max = report->reference.threads;
    report->fds_min = report->fds_max = report->reference.fds;
    for (const Sample& s : samples) {
      report->rss_max_mib = std::max(report->rss_max_mib, s.rss_mib);
      if (s.t_s < report->reference.t_s) continue;
      report->threads_min = std::min(report->threads_min, s.threads);
      report->threads_max = std::max(report->threads_max, s.threads);
      report->fds_min = std::min(report->fds_min, s.fds);
      report->fds_max = std::max(report->fds_max, s.fds);
    }
    if (report->reference.rss_mib > 0.0) {
      report->rss_growth_pct =
          100.0 * (report->end.rss_mib - report->reference.rss_mib) / report->reference.rss_mib;
    }
    const Sample& first = samples.front();
    if (report->end.t_s > first.t_s)
      report->cpu_cores = (report->end.cpu_s - first.cpu_s) / (report->end.t_s - first.t_s);
    if (report->end.t_s > report->reference.t_s) {
      report->cpu_cores_after_reference =
          (report->end.cpu_s - report->reference.cpu_s) / (report->end.t_s - report->reference.t_s);
    }
  }

  // The criteria.
  std::vector<std::string>& fail = report->failures;
  auto text = [](auto&&... parts) {
    std::ostringstream out;
    (out << ... << parts);
    return out.str();
  };
  if (report->interrupted) fail.push_back("interrupted before the end of the load phase");
  if (report->crashed) {
    fail.push_back(
        text("the service died at ", report->exit.at_s, " s: ", report->exit.Describe()));
  } else if (!report->exit.Clean()) {
    fail.push_back(text("after SIGTERM the service ended with ", report->exit.Describe(),
                        " (expected exit code 0)"));
  }
  if (samples.empty() || report->end.t_s <= report->reference.t_s) {
    fail.push_back("no process samples after the reference time");
  } else {
    if (!(report->rss_growth_pct < options.max_rss_growth_pct)) {
      fail.push_back(text("RSS grew ", report->rss_growth_pct, "% from ", report->reference.t_s,
                          " s to the end (limit ", options.max_rss_growth_pct, "%)"));
    }
    if (report->threads_min != report->threads_max) {
      fail.push_back(text("threads changed after ", report->reference.t_s,
                          " s: ", report->threads_min, "..", report->threads_max));
    }
    if (report->fds_min != report->fds_max) {
      fail.push_back(text("file descriptors changed after ", report->reference.t_s,
                          " s: ", report->fds_min, "..", report->fds_max));
    }
  }
  if (!t.has_status) fail.push_back("no status message from the service");
  if (!report->crashed && !report->drained)
    fail.push_back(text("the service did not settle within ", options.drain_timeout_s,
                        " s after the load (busy, or answers missing)"));
  if (report->publish_failures > 0)
    fail.push_back(text(report->publish_failures, " messages could not be published"));
  if (report->crashed) {
    // Counts stop at the last status before the crash; what was in flight is no finding.
    report->notes.push_back(
        "the service died: lost and unanswered counts include what was in flight then");
  } else if (report->lost != 0) {
    std::string where = "dropped before its handler";
    if (report->service_udp_drops == 0) {
      where =
          "no kernel drops on its sockets, so LCM discarded them: its subscription queue "
          "(--subscription-queue) was full";
    } else if (report->service_udp_drops > 0) {
      where = text(report->service_udp_drops, " datagrams dropped by the kernel on its sockets");
    }
    fail.push_back(text(report->lost, " messages lost (sent - answered - dropped - stale): ",
                        report->not_received, " never counted by the service (", where, "), ",
                        report->unaccounted, " received but neither answered nor dropped, ",
                        report->answers_missing, " answers published but not received"));
  }
  if (report->frame_error_unanswered != 0 && !report->crashed) {
    fail.push_back(
        text(report->frame_error_unanswered, " bad frames that fail validation got no answer"));
  }
  int64_t not_error = 0;
  for (size_t c = 0; c < cases.size(); ++c) {
    const KindCounts& k = t.kinds[c];
    not_error += k.not_error;
    if (k.not_error > 0) {
      fail.push_back(text("bad frames '", cases[c].name, "' answered without an error (",
                          k.not_error, "x): ", k.example));
    }
    if (k.other_error > 0) {
      report->notes.push_back(text("bad frames '", cases[c].name, "' answered with another error (",
                                   k.other_error, "x) than '", cases[c].words, "': ", k.example));
    }
  }
  if (t.good.rejected > 0)
    fail.push_back(text(t.good.rejected, " good frames rejected: ", t.good.example));
  // Every gap must be counted, and nothing else: frames the kernel dropped (not received)
  // are gaps too, so they widen the bound.
  if (t.has_status && !report->crashed &&
      (report->service_lost < report->expected_gaps ||
       report->service_lost > report->expected_gaps + report->not_received)) {
    fail.push_back(text("the service counted ", report->service_lost, " frames lost; expected ",
                        report->expected_gaps, " seq gaps (", report->withheld, " withheld)",
                        report->not_received > 0
                            ? text(" plus up to ", report->not_received, " not received")
                            : std::string()));
  }
  if (report->service_out_of_order > 0)
    report->notes.push_back(text(report->service_out_of_order, " frames out of order"));
  if (t.duplicates > 0) fail.push_back(text(t.duplicates, " duplicate answers"));
  if (t.unmatched > 0) fail.push_back(text(t.unmatched, " answers to no message of this run"));
  if (!report->final_status && report->exit.Clean())
    report->notes.push_back(
        "the status published at shutdown did not arrive; counts are from the last one before");
  report->success = fail.empty();
}

// ---- Output --------------------------------------------------------------------------------

void PrintSummary(const SoakOptions& options, const std::vector<BadCase>& cases,
                  const std::string& url, pid_t pid, const SoakReport& r) {
  const Tally& t = r.tally;
  std::printf("\n== g6d-bench-soak: %.1f s at %.1f Hz (%lld messages, %.2f Hz achieved), ",
              r.wall_s, options.rate_hz, static_cast<long long>(r.sent),
              r.wall_s > 0 ? static_cast<double>(r.sent) / r.wall_s : 0.0);
  if (options.bad_every == 0) {
    std::printf("no bad messages ==\n");
  } else if (options.bad_every == 1) {
    std::printf("every message bad ==\n");
  } else {
    std::printf("every %s message bad ==\n", Ordinal(options.bad_every).c_str());
  }
  char ending[64] = "";
  if (r.crashed) std::snprintf(ending, sizeof(ending), "died at %.1f s: ", r.exit.at_s);
  std::printf("service    pid %d on %s; %s%s; crashes %d\n", static_cast<int>(pid), url.c_str(),
              r.crashed ? ending : "after SIGTERM: ", r.exit.Describe().c_str(), r.crashed ? 1 : 0);
  std::printf("messages   sent %lld = %lld good + %lld bad; received by the service %lld\n",
              static_cast<long long>(r.sent), static_cast<long long>(t.good.sent),
              static_cast<long long>(r.sent - t.good.sent), static_cast<long long>(r.received));
  std::printf(
      "           answered %lld, dropped in the mailbox %lld, stale %lld -> lost %lld "
      "(not received %lld, unaccounted %lld, answers missing %lld)\n",
      static_cast<long long>(r.answered), static_cast<long long>(r.dropped),
      static_cast<long long>(r.stale), static_cast<long long>(r.lost),
      static_cast<long long>(r.not_received), static_cast<long long>(r.unaccounted),
      static_cast<long long>(r.answers_missing));
  std::printf("           service: processed %lld (answered OK), rejected %lld (BAD_FRAME)\n",
              static_cast<long long>(r.processed), static_cast<long long>(r.rejected));
  std::printf(
      "seq gaps   withheld %lld good frames; expected gaps %lld; service: lost %lld, "
      "out of order %lld\n",
      static_cast<long long>(r.withheld), static_cast<long long>(r.expected_gaps),
      static_cast<long long>(r.service_lost), static_cast<long long>(r.service_out_of_order));
  std::printf("           kernel UDP drops: service sockets %lld, bench sockets %lld\n",
              static_cast<long long>(r.service_udp_drops),
              static_cast<long long>(r.bench_udp_drops));
  std::printf(
      "good       sent %lld, answered %lld (frame OK %lld, rejected %lld), not answered %lld\n",
      static_cast<long long>(t.good.sent), static_cast<long long>(t.good.answered),
      static_cast<long long>(t.good.frame_ok), static_cast<long long>(t.good.rejected),
      static_cast<long long>(t.good.sent - t.good.answered));
  std::printf("           estimates:");
  for (const auto& [name, count] : t.good.estimates)
    std::printf(" %s %lld", name.c_str(), static_cast<long long>(count));
  std::printf("%s\n", t.good.estimates.empty() ? " none" : "");
  int64_t bad_answered = 0, bad_errors = 0;
  for (const KindCounts& k : t.kinds) {
    bad_answered += k.answered;
    bad_errors += k.expected + k.other_error;
  }
  std::printf("bad        sent %lld, answered %lld, with an error %lld\n",
              static_cast<long long>(r.sent - t.good.sent), static_cast<long long>(bad_answered),
              static_cast<long long>(bad_errors));
  std::printf("  %-32s %7s %9s %9s %8s %9s %11s\n", "kind", "sent", "answered", "expected", "other",
              "no error", "unanswered");
  for (size_t c = 0; c < cases.size(); ++c) {
    const KindCounts& k = t.kinds[c];
    std::printf("  %-32s %7lld %9lld %9lld %8lld %9lld %11lld%s\n",
                (cases[c].name + (cases[c].InstanceError() ? " *" : "")).c_str(),
                static_cast<long long>(k.sent), static_cast<long long>(k.answered),
                static_cast<long long>(k.expected), static_cast<long long>(k.other_error),
                static_cast<long long>(k.not_error), static_cast<long long>(k.sent - k.answered),
                cases[c].seq_known ? "" : " (seq -1)");
  }
  std::printf(
      "  * passes validation, fails per instance: goes through the mailbox like a good frame\n");
  std::printf(
      "mailbox    good + * frames sent %lld, not answered %lld = dropped %lld + stale %lld %s\n",
      static_cast<long long>(r.mailbox_sent), static_cast<long long>(r.mailbox_unanswered),
      static_cast<long long>(r.dropped), static_cast<long long>(r.stale),
      r.mailbox_unanswered == r.dropped + r.stale ? "(exact)" : "(MISMATCH)");
  std::printf("           frames failing validation: sent %lld, not answered %lld\n",
              static_cast<long long>(r.frame_error_sent),
              static_cast<long long>(r.frame_error_unanswered));
  std::printf(
      "latency    good answers (%zu): publish -> answer p50 %.3f s, p95 %.3f s; service total_s "
      "p50 %.3f s, p95 %.3f s\n",
      t.good_latency_s.size(), g6d::Percentile(t.good_latency_s, 0.5),
      g6d::Percentile(t.good_latency_s, 0.95), g6d::Percentile(t.good_service_s, 0.5),
      g6d::Percentile(t.good_service_s, 0.95));
  std::printf("           error answers (%zu): publish -> answer p50 %.1f ms, p95 %.1f ms\n",
              t.error_latency_s.size(), g6d::Percentile(t.error_latency_s, 0.5) * 1e3,
              g6d::Percentile(t.error_latency_s, 0.95) * 1e3);
  std::printf("           service decode (LCM handler) p50 %.1f ms, p95 %.1f ms, max %.1f ms\n",
              g6d::Percentile(t.decode_s, 0.5) * 1e3, g6d::Percentile(t.decode_s, 0.95) * 1e3,
              g6d::Percentile(t.decode_s, 1.0) * 1e3);
  const bool short_run = options.duration_s < 120.0;
  std::printf(
      "memory     RSS at %.0f s%s %.1f MiB, at the end (%.0f s) %.1f MiB: growth %+.2f%% "
      "(limit %.1f%%); max %.1f MiB\n",
      r.reference.t_s, short_run ? " (20% of a run shorter than 2 min, instead of 1 min)" : "",
      r.reference.rss_mib, r.end.t_s, r.end.rss_mib, r.rss_growth_pct, options.max_rss_growth_pct,
      r.rss_max_mib);
  std::printf("threads    after %.0f s: min %d, max %d;  file descriptors: min %d, max %d\n",
              r.reference.t_s, r.threads_min, r.threads_max, r.fds_min, r.fds_max);
  std::printf("cpu        %.2f cores over the run (%.2f after %.0f s), %.1f s CPU\n", r.cpu_cores,
              r.cpu_cores_after_reference, r.reference.t_s, r.end.cpu_s);
  for (const std::string& note : r.notes) std::printf("note       %s\n", note.c_str());
  if (r.success) {
    std::printf("verdict    PASS\n");
  } else {
    std::printf("verdict    FAIL\n");
    for (const std::string& failure : r.failures) std::printf("  - %s\n", failure.c_str());
  }
}

nlohmann::ordered_json SummaryJson(const SoakOptions& options, const std::vector<BadCase>& cases,
                                   const std::string& url, pid_t pid, const SoakReport& r) {
  using Json = nlohmann::ordered_json;
  const Tally& t = r.tally;
  Json kinds = Json::array();
  for (size_t c = 0; c < cases.size(); ++c) {
    const KindCounts& k = t.kinds[c];
    kinds.push_back({{"name", cases[c].name},
                     {"instance_error", cases[c].InstanceError()},
                     {"expected_words", cases[c].words},
                     {"sent", k.sent},
                     {"answered", k.answered},
                     {"expected", k.expected},
                     {"other_error", k.other_error},
                     {"not_error", k.not_error},
                     {"unanswered", k.sent - k.answered},
                     {"example", k.example}});
  }
  auto percentiles = [](const std::vector<double>& values) {
    return Json{{"n", values.size()},
                {"p50", g6d::Percentile(values, 0.5)},
                {"p95", g6d::Percentile(values, 0.95)},
                {"max", g6d::Percentile(values, 1.0)}};
  };
  auto sample = [](const Sample& s) {
    return Json{{"t_s", s.t_s},
                {"rss_mib", s.rss_mib},
                {"threads", s.threads},
                {"fds", s.fds},
                {"cpu_s", s.cpu_s}};
  };
  Json out;
  out["success"] = r.success;
  out["failures"] = r.failures;
  out["notes"] = r.notes;
  out["options"] = {{"service_bin", options.service_bin},
                    {"templates", options.templates_dir},
                    {"log", options.log_path},
                    {"lcm_url", url},
                    {"duration_s", options.duration_s},
                    {"rate_hz", options.rate_hz},
                    {"bad_every", options.bad_every},
                    {"withhold_every", options.withhold_every},
                    {"workers", options.workers},
                    {"hypotheses", options.hypotheses},
                    {"service_args", options.service_args},
                    {"max_rss_growth_pct", options.max_rss_growth_pct}};
  out["wall_s"] = r.wall_s;
  out["interrupted"] = r.interrupted;
  out["service"] = {{"pid", pid},
                    {"crashes", r.crashed ? 1 : 0},
                    {"exit", r.exit.Describe()},
                    {"exit_code", r.exit.code},
                    {"exit_signal", r.exit.signal},
                    {"clean_exit", r.exit.Clean()},
                    {"died_at_s", r.crashed ? r.exit.at_s : -1.0}};
  out["messages"] = {{"sent", r.sent},
                     {"sent_good", t.good.sent},
                     {"sent_bad", r.sent - t.good.sent},
                     {"publish_failures", r.publish_failures},
                     {"received_by_service", r.received},
                     {"answered", r.answered},
                     {"processed", r.processed},
                     {"rejected", r.rejected},
                     {"dropped", r.dropped},
                     {"stale", r.stale},
                     {"lost", r.lost},
                     {"not_received", r.not_received},
                     {"unaccounted", r.unaccounted},
                     {"answers_missing", r.answers_missing},
                     {"service_udp_drops", r.service_udp_drops},
                     {"bench_udp_drops", r.bench_udp_drops},
                     {"duplicate_answers", t.duplicates},
                     {"unmatched_answers", t.unmatched},
                     {"mailbox_sent", r.mailbox_sent},
                     {"mailbox_unanswered", r.mailbox_unanswered},
                     {"frame_error_sent", r.frame_error_sent},
                     {"frame_error_unanswered", r.frame_error_unanswered},
                     {"withheld", r.withheld},
                     {"expected_gaps", r.expected_gaps},
                     {"service_lost", r.service_lost},
                     {"service_out_of_order", r.service_out_of_order}};
  out["good"] = {{"sent", t.good.sent},
                 {"answered", t.good.answered},
                 {"frame_ok", t.good.frame_ok},
                 {"rejected", t.good.rejected},
                 {"estimates", t.good.estimates},
                 {"latency_s", percentiles(t.good_latency_s)},
                 {"service_total_s", percentiles(t.good_service_s)}};
  out["bad"] = {{"kinds", kinds}, {"latency_s", percentiles(t.error_latency_s)}};
  out["service_decode_s"] = percentiles(t.decode_s);
  out["process"] = {{"reference_s", r.reference.t_s},
                    {"reference", sample(r.reference)},
                    {"end", sample(r.end)},
                    {"rss_growth_pct", r.rss_growth_pct},
                    {"rss_max_mib", r.rss_max_mib},
                    {"threads_min", r.threads_min},
                    {"threads_max", r.threads_max},
                    {"fds_min", r.fds_min},
                    {"fds_max", r.fds_max},
                    {"cpu_cores", r.cpu_cores},
                    {"cpu_cores_after_reference", r.cpu_cores_after_reference}};
  return out;
}

void WriteSamplesCsv(const std::string& path, const std::vector<Sample>& samples) {
  std::ofstream out(path);
  if (!out) G6D_THROW("cannot write " << path);
  out << "t,rss_mib,threads,fds,cpu_s,sent,answered,dropped\n";
  char line[256];
  for (const Sample& s : samples) {
    std::snprintf(line, sizeof(line), "%.3f,%.3f,%d,%d,%.3f,%lld,%lld,%lld\n", s.t_s, s.rss_mib,
                  s.threads, s.fds, s.cpu_s, static_cast<long long>(s.sent),
                  static_cast<long long>(s.answered), static_cast<long long>(s.dropped));
    out << line;
  }
}

/// A "nice" tick step (1, 2 or 5 x 10^k) giving about `ticks` ticks over `span`.
double TickStep(double span, int ticks) {
  const double raw = span / std::max(1, ticks);
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0}) {
    if (m * power >= raw) return m * power;
  }
  return 10.0 * power;
}

/// RSS, threads and file descriptors over time, one panel each, the reference time marked.
void DrawPlot(const std::string& path, const std::vector<Sample>& samples, double reference_s,
              const std::string& title) {
  if (samples.empty()) return;
  constexpr int kWidth = 1000, kPanelHeight = 220, kLeft = 80, kRight = 20, kTop = 40, kGap = 40;
  const int height = kTop + 3 * (kPanelHeight + kGap);
  cv::Mat image(height, kWidth, CV_8UC3, cv::Scalar(255, 255, 255));
  const cv::Scalar kBlack(0, 0, 0), kGrey(200, 200, 200), kRed(40, 40, 210);
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  cv::putText(image, title, {kLeft, 25}, font, 0.6, kBlack, 1, cv::LINE_AA);
  const double t_max = std::max(1.0, samples.back().t_s);
  const int plot_width = kWidth - kLeft - kRight;
  struct Series {
    const char* name;
    double (*value)(const Sample&);
    cv::Scalar colour;
  };
  const Series series[] = {
      {"RSS (MiB)", [](const Sample& s) { return s.rss_mib; }, cv::Scalar(180, 90, 20)},
      {"threads", [](const Sample& s) { return static_cast<double>(s.threads); },
       cv::Scalar(30, 140, 30)},
      {"file descriptors", [](const Sample& s) { return static_cast<double>(s.fds); },
       cv::Scalar(20, 120, 200)}};
  for (int p = 0; p < 3; ++p) {
    const Series& s = series[p];
    const int top = kTop + p * (kPanelHeight + kGap) + 15, bottom = top + kPanelHeight - 15;
    double min_value = s.value(samples.front()), max_value = min_value;
    for (const Sample& sample : samples) {
      min_value = std::min(min_value, s.value(sample));
      max_value = std::max(max_value, s.value(sample));
    }
    // Integer series: one unit of margin; RSS: 5% of its level, so small drifts stay small.
    const double margin = p == 0 ? std::max(1.0, 0.05 * max_value) : 1.0;
    const double lo = std::max(0.0, min_value - margin), hi = max_value + margin;
    auto x_of = [&](double t) { return kLeft + static_cast<int>(plot_width * t / t_max); };
    auto y_of = [&](double v) {
      return bottom - static_cast<int>((bottom - top) * (v - lo) / (hi - lo));
    };
    const bool integer = p > 0;
    const double y_step = integer ? std::max(1.0, TickStep(hi - lo, 4)) : TickStep(hi - lo, 4);
    for (double v = std::ceil(lo / y_step) * y_step; v <= hi; v += y_step) {
      cv::line(image, {kLeft, y_of(v)}, {kWidth - kRight, y_of(v)}, kGrey, 1);
      char label[32];
      std::snprintf(label, sizeof(label), y_step < 1.0 ? "%.1f" : "%.0f", v);
      cv::putText(image, label, {5, y_of(v) + 4}, font, 0.4, kBlack, 1, cv::LINE_AA);
    }
    const double t_step = TickStep(t_max, 10);
    for (double t = 0.0; t <= t_max + 1e-9; t += t_step) {
      cv::line(image, {x_of(t), bottom}, {x_of(t), bottom + 4}, kBlack, 1);
      char label[32];
      std::snprintf(label, sizeof(label), "%.0f", t);
      cv::putText(image, label, {x_of(t) - 8, bottom + 16}, font, 0.35, kBlack, 1, cv::LINE_AA);
    }
    cv::rectangle(image, {kLeft, top}, {kWidth - kRight, bottom}, kBlack, 1);
    cv::line(image, {x_of(reference_s), top}, {x_of(reference_s), bottom}, kRed, 1);
    std::vector<cv::Point> points;
    for (const Sample& sample : samples)
      points.emplace_back(x_of(sample.t_s), y_of(s.value(sample)));
    cv::polylines(image, points, false, s.colour, 2, cv::LINE_AA);
    char heading[128];
    std::snprintf(heading, sizeof(heading),
                  integer ? "%s  (min %.0f, max %.0f; red line: reference %.0f s; x: time, s)"
                          : "%s  (min %.1f, max %.1f; red line: reference %.0f s; x: time, s)",
                  s.name, min_value, max_value, reference_s);
    cv::putText(image, heading, {kLeft, top - 5}, font, 0.45, kBlack, 1, cv::LINE_AA);
  }
  if (!cv::imwrite(path, image)) G6D_THROW("cannot write " << path);
}

// ---- The run -------------------------------------------------------------------------------

/// The frames of the log, encoded once; each send patches seq and utime in.
std::vector<std::vector<uint8_t>> LoadGoodFrames(const SoakOptions& options,
                                                 g6d::rgbd_frame_t* first) {
  g6d::FrameLogReader reader(options.log_path, options.log_channel);
  std::vector<std::vector<uint8_t>> frames;
  g6d::FrameEvent event;
  while (reader.Next(&event)) {
    if (frames.empty()) *first = event.frame;
    frames.push_back(g6d::synthetic::EncodeMessage(event.frame));
  }
  for (const std::string& problem : reader.stats().Problems())
    std::fprintf(stderr, "[soak] %s\n", problem.c_str());
  if (frames.empty())
    G6D_THROW(options.log_path << " holds no g6d_rgbd_frame_t on '" << options.log_channel << "'");
  if (first->instances.empty()) G6D_THROW(options.log_path << ": the first frame has no instances");
  return frames;
}

int RunSoak(const SoakOptions& options) {
  // 1. The messages.
  g6d::rgbd_frame_t first;
  std::vector<std::vector<uint8_t>> good_frames = LoadGoodFrames(options, &first);
  first.seq = 0;
  const std::vector<BadCase> cases = g6d::synthetic::MakeBadCases(first);
  std::vector<std::vector<uint8_t>> bad_frames;
  for (const BadCase& bad : cases) bad_frames.push_back(bad.bytes);
  std::printf("[soak] %zu good frames from %s (%.0f kB each), %zu kinds of bad frames\n",
              good_frames.size(), options.log_path.c_str(), good_frames[0].size() / 1024.0,
              cases.size());

  // 2. The service, on a bus of its own.
  const std::string url = options.lcm_url.empty()
                              ? "udpm://239.255.76.67:" + std::to_string(40000 + getpid() % 20000) +
                                    "?ttl=0&recv_buf_size=4194304"
                              : options.lcm_url;
  std::vector<std::string> argv = {options.service_bin,
                                   "--templates",
                                   options.templates_dir,
                                   "--lcm-url",
                                   url,
                                   "--input",
                                   options.input_channel,
                                   "--output",
                                   options.output_channel,
                                   "--status",
                                   options.status_channel,
                                   "--workers",
                                   std::to_string(options.workers)};
  if (options.hypotheses > 0) {
    argv.push_back("--hypotheses");
    argv.push_back(std::to_string(options.hypotheses));
  }
  argv.insert(argv.end(), options.service_args.begin(), options.service_args.end());
  // Subscribed before the service starts, so its first status is not missed.
  lcm::LCM lcm(url);
  if (!lcm.good()) G6D_THROW("cannot open LCM at " << url);
  AnswerCollector collector(&cases);
  // The channels hold no regular-expression characters (LCM subscribes by regex).
  lcm.subscribe(options.output_channel, &AnswerCollector::OnAnswer, &collector)
      ->setQueueCapacity(1000000);
  lcm.subscribe(options.status_channel, &AnswerCollector::OnStatus, &collector)
      ->setQueueCapacity(1000);

  ServiceProcess service(argv, options.service_log);
  std::printf("[soak] g6d-service pid %d on %s (log %s)\n", static_cast<int>(service.pid()),
              url.c_str(), options.service_log.c_str());
  LcmHandleThread pump(&lcm);
  {
    const Clock::time_point deadline =
        Clock::now() + std::chrono::duration_cast<Clock::duration>(
                           std::chrono::duration<double>(options.startup_timeout_s));
    bool ready = false;
    // One-second slices so that a service dying while it loads is seen at once.
    while (!ready && Clock::now() < deadline && !g_interrupted) {
      ready = collector.WaitForStatusSince(0, std::chrono::seconds(1));
      if (!ready && service.Exited(0.0)) {
        std::fprintf(stderr, "[soak] g6d-service ended while starting: %s; its log:\n%s",
                     service.exit_info().Describe().c_str(), Tail(options.service_log, 20).c_str());
        return 1;
      }
    }
    if (!ready) {
      std::fprintf(stderr, "[soak] no status from g6d-service within %.0f s; its log:\n%s",
                   options.startup_timeout_s, Tail(options.service_log, 20).c_str());
      return 2;
    }
    if (collector.Snapshot().status.num_objects == 0)
      std::fprintf(stderr, "[soak] warning: the service loaded no template cache\n");
  }

  // 3. The load: a fixed-rate source (sleep_until, like a camera driver) and a sample of
  // the process every second.
  SoakReport report;
  std::vector<Sample> samples;
  const auto period = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(1.0 / options.rate_hz));
  const int64_t total = std::max<int64_t>(1, std::llround(options.duration_s * options.rate_hz));
  const Clock::time_point start = Clock::now();
  Clock::time_point next_sample = start, next_progress = start;
  size_t next_good = 0, next_bad = 0;
  int64_t pending_gaps = 0;  // seqs the service cannot see since the last one it can
  bool named_sent = false;   // a message with a readable seq was sent
  std::printf("[soak] %lld messages at %.1f Hz for %.0f s; progress every %.0f s\n",
              static_cast<long long>(total), options.rate_hz, options.duration_s,
              options.progress_s);
  auto take_sample = [&](Clock::time_point at) {
    Sample sample;
    sample.t_s = Seconds(at - start);
    // A process that ends between the two calls is a zombie that ReadProcess() cannot read
    // and the second Exited() reaps.
    if (service.Exited(sample.t_s) ||
        (!ReadProcess(service.pid(), &sample) && service.Exited(sample.t_s))) {
      report.crashed = true;
      return;
    }
    sample.sent = report.sent;
    sample.answered = collector.answered();
    const Tally tally = collector.Snapshot();
    sample.dropped = tally.status.frames_dropped;
    samples.push_back(sample);
    if (at >= next_progress) {
      int64_t errors = 0;
      for (const KindCounts& k : tally.kinds) errors += k.expected + k.other_error;
      std::printf(
          "[soak] %5.0f s: sent %lld, answered %lld (%lld errors), dropped %lld, RSS %.1f MiB, "
          "threads %d, fds %d, cpu %.1f s\n",
          sample.t_s, static_cast<long long>(sample.sent), static_cast<long long>(sample.answered),
          static_cast<long long>(errors), static_cast<long long>(sample.dropped), sample.rss_mib,
          sample.threads, sample.fds, sample.cpu_s);
      next_progress += std::chrono::duration_cast<Clock::duration>(
          std::chrono::duration<double>(options.progress_s));
    }
  };
  for (int64_t i = 0; i < total && !report.crashed && !g_interrupted; ++i) {
    const Clock::time_point send_at = start + i * period;
    while (next_sample <= send_at && !report.crashed) {
      std::this_thread::sleep_until(next_sample);
      take_sample(next_sample);
      next_sample += std::chrono::seconds(1);
    }
    if (report.crashed) break;
    std::this_thread::sleep_until(send_at);
    const int64_t seq = i + 1;
    const bool bad = options.bad_every > 0 && (i + 1) % options.bad_every == 0;
    std::vector<uint8_t>* bytes;
    int kind = -1;
    if (bad) {
      kind = static_cast<int>(next_bad++ % bad_frames.size());
      bytes = &bad_frames[kind];
    } else {
      const size_t good_index = next_good++;
      if (options.withhold_every > 0 &&
          (good_index + 1) % static_cast<size_t>(options.withhold_every) == 0) {
        collector.Withheld(seq);
        ++report.withheld;
        ++pending_gaps;
        continue;
      }
      bytes = &good_frames[good_index % good_frames.size()];
    }
    // A seq the service can read ends the gap before it (none before its first one).
    if (kind >= 0 && !cases[kind].seq_known) {
      ++pending_gaps;
    } else {
      if (named_sent) report.expected_gaps += pending_gaps;
      pending_gaps = 0;
      named_sent = true;
    }
    if (kind < 0 || cases[kind].seq_known) {
      g6d::synthetic::PatchSeq(bytes, seq);
      g6d::synthetic::PatchUtime(bytes, NowUtime());
    }
    collector.Sent(seq, kind, Clock::now());
    if (lcm.publish(options.input_channel, bytes->data(), static_cast<unsigned>(bytes->size())) !=
        0)
      ++report.publish_failures;
    ++report.sent;
  }
  report.interrupted = g_interrupted != 0;
  if (!report.crashed) {
    // The end of the load, one period after the last message (or now, when interrupted).
    const Clock::time_point end = report.interrupted ? Clock::now() : start + total * period;
    std::this_thread::sleep_until(end);
    take_sample(std::max(end, Clock::now()));
  }
  report.wall_s = Seconds(Clock::now() - start);

  // 4. Drain: the last frame in flight is solved and every published answer arrives.
  if (!report.crashed) {
    const int64_t load_end_utime = NowUtime();
    const Clock::time_point deadline =
        Clock::now() + std::chrono::duration_cast<Clock::duration>(
                           std::chrono::duration<double>(options.drain_timeout_s));
    while (!report.drained && Clock::now() < deadline) {
      report.drained = collector.WaitForDrain(load_end_utime, std::chrono::seconds(1));
      if (service.Exited(Seconds(Clock::now() - start))) {
        report.crashed = true;
        break;
      }
    }
  }

  // 5. SIGTERM and the exit; then the status it published while stopping.
  const int64_t stop_utime = NowUtime();
  if (!report.crashed) {
    report.service_udp_drops = UdpDrops(service.pid());
    report.bench_udp_drops = UdpDrops(0);
    service.Terminate(options.exit_timeout_s, Seconds(Clock::now() - start));
    report.final_status = collector.WaitForStatusSince(stop_utime, std::chrono::seconds(2));
  }
  report.exit = service.exit_info();
  report.tally = collector.Snapshot();
  Evaluate(options, cases, samples, &report);

  PrintSummary(options, cases, url, service.pid(), report);
  if (report.crashed)
    std::printf("the end of the service log (%s):\n%s", options.service_log.c_str(),
                Tail(options.service_log, 20).c_str());
  if (!options.summary_json.empty()) {
    std::ofstream out(options.summary_json);
    if (!out) G6D_THROW("cannot write " << options.summary_json);
    out << SummaryJson(options, cases, url, service.pid(), report).dump(2) << "\n";
  }
  if (!options.samples_csv.empty()) WriteSamplesCsv(options.samples_csv, samples);
  if (!options.plot_png.empty()) {
    char title[256];
    std::snprintf(title, sizeof(title),
                  "g6d-service soak: %.0f s at %.0f Hz, RSS %+.2f%% from %.0f s, %s", report.wall_s,
                  options.rate_hz, report.rss_growth_pct, report.reference.t_s,
                  report.success ? "PASS" : "FAIL");
    DrawPlot(options.plot_png, samples, report.reference.t_s, title);
  }
  return report.success ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "g6d-bench-soak: g6d-service (a child process) under a fixed-rate mix of good and bad "
      "frames for a long time: answers, errors, crashes, memory, threads, descriptors"};
  SoakOptions options;
  options.service_bin = std::string(G6D_BINARY_DIR) + "/service/g6d-service";
  app.add_option("--service-bin", options.service_bin, "g6d-service executable")
      ->capture_default_str();
  app.add_option("--templates", options.templates_dir, "template cache folder of the service")
      ->required();
  app.add_option("--log", options.log_path, "LCM log of g6d_rgbd_frame_t (the good frames)")
      ->required();
  app.add_option("--log-channel", options.log_channel, "frame channel in the log")
      ->capture_default_str();
  app.add_option("--lcm-url", options.lcm_url,
                 "LCM URL (default: udpm on a port of this process, ttl=0, 4 MB receive buffer)");
  app.add_option("--input", options.input_channel, "frame channel")->capture_default_str();
  app.add_option("--output", options.output_channel, "answer channel")->capture_default_str();
  app.add_option("--status", options.status_channel, "status channel")->capture_default_str();
  app.add_option("--duration-s", options.duration_s, "length of the load, seconds")
      ->capture_default_str();
  app.add_option("--rate-hz", options.rate_hz, "messages per second, good and bad")
      ->capture_default_str();
  app.add_option("--withhold-every", options.withhold_every,
                 "withhold every Nth good frame (its seq is skipped; the service must count "
                 "it lost; 0 = none)")
      ->capture_default_str();
  app.add_option("--bad-every", options.bad_every, "every Nth message is bad (0 = none)")
      ->capture_default_str();
  app.add_option("--workers", options.workers, "--workers of the service")->capture_default_str();
  app.add_option("--hypotheses", options.hypotheses,
                 "--hypotheses K of the service (0 = its default)")
      ->capture_default_str();
  app.add_option("--service-arg", options.service_args,
                 "one more argument for the service, repeatable (--service-arg=--max-age-ms=500)");
  app.add_option("--max-rss-growth-pct", options.max_rss_growth_pct,
                 "largest RSS growth from 1 min (20% of a short run) to the end that passes, %")
      ->capture_default_str();
  app.add_option("--startup-timeout-s", options.startup_timeout_s,
                 "wait for the service's first status, seconds")
      ->capture_default_str();
  app.add_option("--drain-timeout-s", options.drain_timeout_s,
                 "wait for the last answers after the load, seconds")
      ->capture_default_str();
  app.add_option("--exit-timeout-s", options.exit_timeout_s,
                 "wait for the exit after SIGTERM before SIGKILL, seconds")
      ->capture_default_str();
  app.add_option("--progress-s", options.progress_s, "period of the progress lines, seconds")
      ->capture_default_str();
  app.add_option("--service-log", options.service_log, "the service's stdout and stderr")
      ->capture_default_str();
  app.add_option("--summary-json", options.summary_json, "write the summary as JSON");
  app.add_option(
      "--samples-csv", options.samples_csv,
      "write one row per second: t, rss_mib, threads, fds, cpu_s, sent, answered, dropped");
  app.add_option("--plot", options.plot_png, "draw RSS, threads and descriptors over time (PNG)");
  CLI11_PARSE(app, argc, argv);
  if (const std::string error = options.Check(); !error.empty()) {
    std::fprintf(stderr, "g6d-bench-soak: %s\n", error.c_str());
    return 2;
  }
  // Line by line even into a pipe (scripts/soak.sh tees it): progress shows as it happens.
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  std::signal(SIGINT, OnInterrupt);
  std::signal(SIGTERM, OnInterrupt);
  std::signal(SIGPIPE, SIG_IGN);
  try {
    return RunSoak(options);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "g6d-bench-soak: %s\n", e.what());
    return 2;
  }
}
