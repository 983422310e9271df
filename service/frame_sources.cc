#include "service/frame_sources.h"

#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdlib>
#include <sstream>

#include "g6d/rgbd_frame_t.hpp"

namespace g6d {

FrameSources::FrameSources(int64_t restart_window, Clock::duration warn_period)
    : restart_window_(restart_window), warn_period_(warn_period) {}

std::string FrameSources::Record(const std::string& camera_id, int64_t seq, bool has_seq,
                                 Clock::time_point now) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto found = sources_.find(camera_id);
  if (found == sources_.end()) {
    const bool full = sources_.size() >= kMaxSources;
    const std::string id = full ? kOtherSources : camera_id;
    found = sources_.find(id);
    if (found == sources_.end()) {
      found = sources_.emplace(id, Source()).first;
      found->second.counts.id = id;
      found->second.counts.has_seq = has_seq && !full;  // seqs of several cameras do not compare
    }
  }
  Source& source = found->second;
  ++source.counts.received;
  if (!source.counts.has_seq) return "";
  Count(seq, &source);
  return DueWarning(&source, now);
}

void FrameSources::Count(int64_t seq, Source* source) const {
  SourceCounts& counts = source->counts;
  if (counts.received == 1) {
    counts.last_seq = seq;
  } else if (seq > counts.last_seq) {
    const int64_t lost = seq - counts.last_seq - 1;
    counts.lost += lost;
    source->unlogged_lost += lost;
    counts.last_seq = seq;
  } else if (seq > counts.last_seq - restart_window_) {
    ++counts.out_of_order;
    ++source->unlogged_out_of_order;
  } else {
    ++counts.restarts;
    ++source->unlogged_restarts;
    counts.last_seq = seq;
  }
}

std::string FrameSources::DueWarning(Source* source, Clock::time_point now) const {
  if (source->unlogged_lost == 0 && source->unlogged_out_of_order == 0 &&
      source->unlogged_restarts == 0) {
    return "";
  }
  if (source->warned && now - source->last_warning < warn_period_) return "";
  const SourceCounts& counts = source->counts;
  std::ostringstream text;
  text << "camera '" << counts.id << "': ";
  if (source->unlogged_lost > 0) {
    text << source->unlogged_lost << (source->unlogged_lost == 1 ? " frame" : " frames")
         << " lost (seq gaps)";
  }
  if (source->unlogged_out_of_order > 0) {
    text << (source->unlogged_lost > 0 ? ", " : "") << source->unlogged_out_of_order
         << " out of order";
  }
  if (source->unlogged_restarts > 0) {
    text << (source->unlogged_lost + source->unlogged_out_of_order > 0 ? ", " : "")
         << "publisher restarted (seq went back) " << source->unlogged_restarts << " times";
  }
  text << (source->warned ? " since the last warning" : "") << "; since start: received "
       << counts.received << ", lost " << counts.lost << ", out of order " << counts.out_of_order
       << ", last seq " << counts.last_seq;
  source->unlogged_lost = source->unlogged_out_of_order = source->unlogged_restarts = 0;
  source->last_warning = now;
  source->warned = true;
  return text.str();
}

std::vector<SourceCounts> FrameSources::Sources() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<SourceCounts> sources;
  for (const auto& [id, source] : sources_) sources.push_back(source.counts);
  return sources;
}

SourceCounts FrameSources::Total() const {
  SourceCounts total;
  for (const SourceCounts& source : Sources()) {
    total.received += source.received;
    total.lost += source.lost;
    total.out_of_order += source.out_of_order;
    total.restarts += source.restarts;
  }
  return total;
}

namespace {

// LCM's own default when no URL is given (lcm.c).
constexpr const char* kLcmDefaultUrl = "udpm://239.255.76.67:7667?ttl=0";

// The value of `key` in the URL's query ("?a=1&b=2"), or empty.
std::string QueryValue(const std::string& url, const std::string& key) {
  const size_t query = url.find('?');
  if (query == std::string::npos) return "";
  std::istringstream options(url.substr(query + 1));
  std::string option;
  while (std::getline(options, option, '&')) {
    const size_t equals = option.find('=');
    if (equals != std::string::npos && option.substr(0, equals) == key) {
      return option.substr(equals + 1);
    }
  }
  return "";
}

}  // namespace

bool PeekRgbdFrameSource(const void* data, int64_t size, std::string* camera_id, int64_t* seq) {
  // LCM's encoding: fingerprint, utime, seq (big-endian int64), then camera_id as an int32
  // length that counts the terminating NUL, and the bytes.
  const auto* bytes = static_cast<const uint8_t*>(data);
  auto read = [&](int64_t offset, int width) {
    uint64_t value = 0;
    for (int i = 0; i < width; ++i) value = value << 8 | bytes[offset + i];
    return value;
  };
  constexpr int64_t kCameraIdAt = 24;
  if (data == nullptr || size < kCameraIdAt + 4) return false;
  if (static_cast<int64_t>(read(0, 8)) != rgbd_frame_t::getHash()) return false;
  const int64_t length = static_cast<int32_t>(read(kCameraIdAt, 4));
  if (length < 1 || length > size - kCameraIdAt - 4) return false;
  *seq = static_cast<int64_t>(read(16, 8));
  camera_id->assign(reinterpret_cast<const char*>(bytes + kCameraIdAt + 4),
                    static_cast<size_t>(length - 1));
  return true;
}

ReceiveBuffer ProbeReceiveBuffer(const std::string& lcm_url) {
  ReceiveBuffer buffer;
  buffer.url = lcm_url;
  if (buffer.url.empty()) {
    const char* from_environment = std::getenv("LCM_DEFAULT_URL");
    buffer.url = from_environment != nullptr && *from_environment != '\0' ? from_environment
                                                                          : kLcmDefaultUrl;
  }
  buffer.udpm = buffer.url.rfind("udpm://", 0) == 0;
  if (!buffer.udpm) return buffer;
  // Parsed like LCM does (strtol, base 0); a value LCM cannot read leaves it at 0 there too.
  buffer.requested_bytes = std::strtoll(QueryValue(buffer.url, "recv_buf_size").c_str(), nullptr, 0);
  const int probe = socket(AF_INET, SOCK_DGRAM, 0);
  if (probe < 0) return buffer;
  if (buffer.requested_bytes > 0) {
    const int requested = static_cast<int>(buffer.requested_bytes);
    setsockopt(probe, SOL_SOCKET, SO_RCVBUF, &requested, sizeof(requested));
  }
  int granted = 0;
  socklen_t size = sizeof(granted);
  if (getsockopt(probe, SOL_SOCKET, SO_RCVBUF, &granted, &size) == 0) buffer.granted_bytes = granted;
  close(probe);
  return buffer;
}

std::string ReceiveBufferWarning(const ReceiveBuffer& buffer, int64_t frame_bytes,
                                 const std::string& frame) {
  // The kernel charges each datagram's buffer overhead to SO_RCVBUF too; LCM's fragments
  // are large (up to 64 kB on loopback), so the payload it holds is close to the value.
  if (!buffer.udpm || buffer.granted_bytes <= 0 || buffer.granted_bytes >= frame_bytes) return "";
  std::ostringstream text;
  text << "the LCM receive buffer (" << buffer.granted_bytes << " bytes granted by the kernel"
       << (buffer.requested_bytes > 0
               ? ", " + std::to_string(buffer.requested_bytes) + " requested"
               : std::string(", kernel default"))
       << ") cannot hold one frame (" << frame_bytes << " bytes"
       << (frame.empty() ? "" : ", " + frame)
       << "): the kernel drops a frame's fragments whenever LCM's receive thread falls "
          "behind, and the frame is lost. Add ?recv_buf_size=N to the LCM URL ('"
       << buffer.url
       << "') with N a few frames, and raise the kernel's cap to match (sudo sysctl -w "
          "net.core.rmem_max=N)";
  return text.str();
}

}  // namespace g6d
