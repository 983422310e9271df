#include "eval/bop_csv.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <utility>

#include "core/error.h"

namespace g6d {
namespace {

constexpr const char* kHeader = "scene_id,im_id,obj_id,score,R,t,time";
constexpr double kMillimetresPerMetre = 1000.0;

// Splits on `separator`, keeping empty fields.
std::vector<std::string> Split(const std::string& text, char separator) {
  std::vector<std::string> fields;
  std::string field;
  std::istringstream stream(text);
  while (std::getline(stream, field, separator)) fields.push_back(field);
  if (!text.empty() && text.back() == separator) fields.emplace_back();
  return fields;
}

std::string Trim(const std::string& text) {
  const char* kSpace = " \t\r\n";
  const size_t begin = text.find_first_not_of(kSpace);
  if (begin == std::string::npos) return "";
  return text.substr(begin, text.find_last_not_of(kSpace) - begin + 1);
}

// Whitespace-separated doubles; all finite.
std::vector<double> ParseNumbers(const std::string& text, const std::string& where,
                                 const char* field) {
  std::vector<double> numbers;
  const char* cursor = text.c_str();
  while (true) {
    while (*cursor == ' ' || *cursor == '\t') ++cursor;
    if (*cursor == '\0') break;
    char* end = nullptr;
    errno = 0;
    const double value = std::strtod(cursor, &end);
    if (end == cursor || (*end != '\0' && *end != ' ' && *end != '\t')) {
      G6D_THROW(where << ": field '" << field << "': '" << text << "' is not a list of numbers");
    }
    if (!std::isfinite(value) || errno == ERANGE) {
      G6D_THROW(where << ": field '" << field << "': value out of range or not finite in '" << text
                      << "'");
    }
    numbers.push_back(value);
    cursor = end;
  }
  return numbers;
}

double ParseNumber(const std::string& text, const std::string& where, const char* field) {
  const std::vector<double> numbers = ParseNumbers(text, where, field);
  if (numbers.size() != 1) {
    G6D_THROW(where << ": field '" << field << "': expected one number, got '" << text << "'");
  }
  return numbers[0];
}

int ParseInt(const std::string& text, const std::string& where, const char* field) {
  const std::string trimmed = Trim(text);
  char* end = nullptr;
  errno = 0;
  const long value = std::strtol(trimmed.c_str(), &end, 10);
  if (trimmed.empty() || *end != '\0' || errno == ERANGE || value < 0 ||
      value > std::numeric_limits<int>::max()) {
    G6D_THROW(where << ": field '" << field << "': expected a non-negative integer, got '" << text
                    << "'");
  }
  return static_cast<int>(value);
}

bool AllFinite(const BopEstimate& estimate) {
  return std::isfinite(estimate.score) && std::isfinite(estimate.time_s) &&
         estimate.cam_from_object.matrix().allFinite();
}

}  // namespace

void WriteBopCsv(const std::vector<BopEstimate>& estimates, std::ostream* out) {
  // One time per image (BOP rule); remember the first estimate index of each image.
  std::map<std::pair<int, int>, size_t> first_of_image;
  for (size_t i = 0; i < estimates.size(); ++i) {
    const BopEstimate& estimate = estimates[i];
    if (!AllFinite(estimate)) {
      G6D_THROW("WriteBopCsv: estimate " << i << " (scene " << estimate.scene_id << ", image "
                                         << estimate.im_id << ", object " << estimate.obj_id
                                         << ") has a non-finite score, time or pose");
    }
    const auto [it, inserted] =
        first_of_image.emplace(std::make_pair(estimate.scene_id, estimate.im_id), i);
    if (!inserted && estimates[it->second].time_s != estimate.time_s) {
      G6D_THROW("WriteBopCsv: estimates "
                << it->second << " and " << i << " of scene " << estimate.scene_id << " image "
                << estimate.im_id << " have different times (" << estimates[it->second].time_s
                << " s vs " << estimate.time_s << " s); BOP needs one time per image");
    }
  }

  std::ostringstream text;
  text.precision(std::numeric_limits<double>::max_digits10);
  text << kHeader << "\n";
  for (const BopEstimate& estimate : estimates) {
    text << estimate.scene_id << "," << estimate.im_id << "," << estimate.obj_id << ","
         << estimate.score << ",";
    const Eigen::Matrix3d rotation = estimate.cam_from_object.linear();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) text << (r + c > 0 ? " " : "") << rotation(r, c);
    }
    text << ",";
    const Eigen::Vector3d t_mm = estimate.cam_from_object.translation() * kMillimetresPerMetre;
    text << t_mm.x() << " " << t_mm.y() << " " << t_mm.z() << "," << estimate.time_s << "\n";
  }
  *out << text.str();
}

void WriteBopCsv(const std::string& path, const std::vector<BopEstimate>& estimates) {
  std::ofstream file(path);
  if (!file) G6D_THROW("cannot open " << path << " for writing");
  WriteBopCsv(estimates, &file);
  file.flush();
  if (!file) G6D_THROW("failed writing " << path);
}

std::vector<BopEstimate> ReadBopCsv(std::istream& in, const std::string& source) {
  std::vector<BopEstimate> estimates;
  std::map<std::pair<int, int>, std::pair<double, int>> time_of_image;  // -> (time, line)
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string trimmed = Trim(line);
    if (trimmed.empty()) continue;
    const std::string where = source + ":" + std::to_string(line_number);
    // The number parsers stop at a NUL byte, so "0.5<NUL>junk" would read as 0.5.
    if (trimmed.find('\0') != std::string::npos) {
      G6D_THROW(where << ": line contains a NUL byte (not a text file?)");
    }
    if (trimmed == kHeader) continue;
    const std::vector<std::string> fields = Split(trimmed, ',');
    if (fields.size() != 7) {
      G6D_THROW(where << ": expected 7 comma-separated fields (" << kHeader << "), got "
                      << fields.size());
    }
    BopEstimate estimate;
    estimate.scene_id = ParseInt(fields[0], where, "scene_id");
    estimate.im_id = ParseInt(fields[1], where, "im_id");
    estimate.obj_id = ParseInt(fields[2], where, "obj_id");
    estimate.score = ParseNumber(fields[3], where, "score");
    const std::vector<double> r = ParseNumbers(fields[4], where, "R");
    if (r.size() != 9) {
      G6D_THROW(where << ": field 'R': expected 9 numbers (row-major 3x3), got " << r.size());
    }
    const std::vector<double> t = ParseNumbers(fields[5], where, "t");
    if (t.size() != 3) {
      G6D_THROW(where << ": field 't': expected 3 numbers (mm), got " << t.size());
    }
    estimate.time_s = ParseNumber(fields[6], where, "time");
    for (int row = 0; row < 3; ++row) {
      for (int col = 0; col < 3; ++col) {
        estimate.cam_from_object.linear()(row, col) = r[3 * row + col];
      }
      estimate.cam_from_object.translation()[row] = t[row] / kMillimetresPerMetre;
    }
    const auto [it, inserted] =
        time_of_image.emplace(std::make_pair(estimate.scene_id, estimate.im_id),
                              std::make_pair(estimate.time_s, line_number));
    if (!inserted && it->second.first != estimate.time_s) {
      G6D_THROW(where << ": time " << estimate.time_s << " differs from " << it->second.first
                      << " on line " << it->second.second << " for scene " << estimate.scene_id
                      << " image " << estimate.im_id << " (BOP needs one time per image)");
    }
    estimates.push_back(estimate);
  }
  if (in.bad()) G6D_THROW(source << ": read error after line " << line_number);
  return estimates;
}

std::vector<BopEstimate> ReadBopCsv(const std::string& path) {
  std::ifstream file(path);
  if (!file) G6D_THROW("cannot open BOP results file " << path);
  return ReadBopCsv(file, path);
}

}  // namespace g6d
