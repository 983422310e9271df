#pragma once
/// @file frame_sources.h
/// Frames that never arrived, made visible: per source (a frame's camera_id) the service
/// counts what arrived, the gaps in the publisher's seq (lost: dropped by the kernel when
/// the socket receive buffer overflowed, by LCM's subscription queue, or by the network)
/// and frames that came out of order. And the check of the LCM socket's receive buffer
/// against the size of one frame, which is the usual reason frames are lost.
///
/// Seq rules (FrameSources::Record), per source:
///  - the first frame of a source only sets its last seq (frames before it are not "lost":
///    the service may have started mid-stream);
///  - seq = last + 1 + n: n frames lost;
///  - last - restart_window < seq <= last: out of order (late or repeated); the last seq
///    stays, so a late frame is not counted twice and a gap seen earlier stays lost;
///  - seq <= last - restart_window: the publisher restarted (its seq began again): counted
///    as a restart, the seq is taken as the new last, nothing is lost.
/// bot_core.images_t carries no seq: its frames are counted as received only
/// (Record with has_seq = false; lost and out of order stay 0, last seq -1).
/// A message the service rejects counts under its camera when its camera_id and seq can
/// still be read (g6d frames with an intact start, PeekRgbdFrameSource); one that cannot be
/// read at all (another type, garbage, a drake array that does not decode) names no source,
/// so its seq shows as a gap of its camera: it is counted in frames_rejected and lost both.

#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace g6d {

/// What one source has sent so far.
struct SourceCounts {
  std::string id;            ///< camera_id of its frames
  bool has_seq = true;       ///< false when its input type carries no seq (bot_core)
  int64_t received = 0;      ///< frames that arrived
  int64_t lost = 0;          ///< frames missing between consecutive seqs
  int64_t out_of_order = 0;  ///< frames with seq <= the last seen (within restart_window)
  int64_t restarts = 0;      ///< seq went back by restart_window or more
  int64_t last_seq = -1;     ///< highest seq of the current run; -1 before the first or without seq
};

/// Per-source arrival counts. Thread-safe: the LCM thread records, the status thread reads.
class FrameSources {
 public:
  using Clock = std::chrono::steady_clock;

  /// Sources kept at most; frames of further camera ids are counted under kOtherSources,
  /// so a publisher with a new camera id per frame cannot grow the status without bound.
  static constexpr size_t kMaxSources = 16;
  static constexpr const char* kOtherSources = "(other)";

  /// `restart_window`: a seq this many frames or more below the last is a publisher
  /// restart (about 3 s at 30 Hz by default; a late frame is never that late: LCM keeps a
  /// source's fragments in order). `warn_period`: at most one loss warning per source per
  /// period.
  explicit FrameSources(int64_t restart_window = 100,
                        Clock::duration warn_period = std::chrono::seconds(5));

  /// Records a frame of `camera_id` with `seq` (ignored when !has_seq) at `now`. Returns
  /// a warning to log when frames of this source were lost or came out of order since its
  /// last warning and the last warning is at least warn_period old; else empty.
  std::string Record(const std::string& camera_id, int64_t seq, bool has_seq,
                     Clock::time_point now = Clock::now());

  /// Every source so far, ordered by id.
  std::vector<SourceCounts> Sources() const;
  /// Sums over the sources (id empty, last_seq -1).
  SourceCounts Total() const;

 private:
  /// A source and what its next warning will report.
  struct Source {
    SourceCounts counts;
    int64_t unlogged_lost = 0, unlogged_out_of_order = 0, unlogged_restarts = 0;
    Clock::time_point last_warning;
    bool warned = false;
  };
  void Count(int64_t seq, Source* source) const;
  std::string DueWarning(Source* source, Clock::time_point now) const;

  const int64_t restart_window_;
  const Clock::duration warn_period_;
  mutable std::mutex mutex_;
  std::map<std::string, Source> sources_;
};

/// Reads camera_id and seq of an encoded g6d.rgbd_frame_t whose body may be malformed (a
/// frame the service rejects still arrived: it is counted under its camera, not as a gap).
/// False when the fingerprint is not rgbd_frame_t's or the bytes end before camera_id.
bool PeekRgbdFrameSource(const void* data, int64_t size, std::string* camera_id, int64_t* seq);

/// The receive buffer of the LCM socket, as the kernel grants it.
struct ReceiveBuffer {
  bool udpm = false;            ///< the URL is udpm (other providers have no socket buffer)
  std::string url;              ///< the URL looked at (LCM's default resolved)
  int64_t requested_bytes = 0;  ///< recv_buf_size of the URL; 0 = not given (kernel default)
  int64_t granted_bytes = 0;    ///< SO_RCVBUF as getsockopt reports it; 0 when unknown
};

/// An RGB8 + DEPTH_U16 + LABEL_U8 640x480 frame, uncompressed, bytes: the frame size the
/// start-up check assumes before a frame has arrived.
constexpr int64_t kVgaFrameBytes = 640 * 480 * (3 + 2 + 1);

/// The receive buffer a socket opened as LCM opens its udpm receive socket gets for
/// `lcm_url` (empty = $LCM_DEFAULT_URL, else LCM's default udpm URL). LCM does not expose
/// its own socket (lcm_get_fileno gives a notification pipe for udpm), so this opens a
/// probe UDP socket, asks for the URL's recv_buf_size like LCM does, and reads what the
/// kernel granted (capped by net.core.rmem_max; Linux reports twice the request).
ReceiveBuffer ProbeReceiveBuffer(const std::string& lcm_url);

/// A warning when `buffer` cannot hold one frame of `frame_bytes` (`frame`: which frame,
/// for the message), naming the URL option and the sysctl to change; empty when it can or
/// when the URL is not udpm.
std::string ReceiveBufferWarning(const ReceiveBuffer& buffer, int64_t frame_bytes,
                                 const std::string& frame = "");

}  // namespace g6d
