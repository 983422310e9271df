#pragma once
/// @file bop_csv.h
/// BOP results CSV (bop_toolkit docs/bop_challenge_2019.md, "Format of results"):
///
///   scene_id,im_id,obj_id,score,R,t,time
///   2,8,1,0.93,r11 r12 r13 r21 r22 r23 r31 r32 r33,tx ty tz,0.412
///
/// R is the row-major rotation of cam_from_object, t its translation in millimetres, time
/// the wall-clock seconds spent on the whole image (BOP requires the same value for every
/// estimate of an image; -1 means unknown). Inside g6d the translation is in metres; the
/// mm conversion happens only here. Numbers are written with 17 significant digits, so
/// ids, score, R and time survive a write/read round trip bit for bit; t goes through one
/// m -> mm -> m conversion and comes back within an ulp or so.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <istream>
#include <ostream>
#include <string>
#include <vector>

namespace g6d {

/// One row of a BOP results file.
struct BopEstimate {
  int scene_id = 0;    ///< BOP scene id
  int im_id = 0;       ///< BOP image id within the scene
  int obj_id = 0;      ///< BOP object id
  double score = 0.0;  ///< confidence, higher is better (BOP ranks by it)
  /// Estimated pose, translation in metres (millimetres only in the file).
  Eigen::Isometry3d cam_from_object = Eigen::Isometry3d::Identity();
  double time_s = -1.0;  ///< seconds for the whole image (same for its estimates), or -1
};

/// Writes the header and one line per estimate to `out`. Throws g6d::Error when an
/// estimate has a non-finite number, or two estimates of the same (scene_id, im_id) have
/// different time_s (BOP rejects such files), naming both.
void WriteBopCsv(const std::vector<BopEstimate>& estimates, std::ostream* out);

/// Writes a results file at `path` (see the stream overload). Throws g6d::Error naming
/// the path when it cannot be written.
void WriteBopCsv(const std::string& path, const std::vector<BopEstimate>& estimates);

/// Parses a results CSV. `source` names the input in error messages ("<source>:<line>:").
/// Accepts the exact BOP header (optional), blank lines and CRLF line ends. Throws
/// g6d::Error with the line number on a wrong field count, a bad number, non-finite values,
/// a NUL byte, or a time that differs from an earlier line of the same image.
std::vector<BopEstimate> ReadBopCsv(std::istream& in, const std::string& source);

/// Reads a results file; throws g6d::Error naming the path when it cannot be opened.
std::vector<BopEstimate> ReadBopCsv(const std::string& path);

}  // namespace g6d
