#include "eval/bop.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "core/error.h"

namespace g6d {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// BOP files are in millimetres; g6d works in metres.
constexpr double kMetresPerMillimetre = 0.001;

// "000005" style names of scene folders and image files.
std::string SixDigits(int value) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%06d", value);
  return buffer;
}

// The whole text of a file; throws naming the path when it cannot be opened or read.
std::string ReadText(const fs::path& path) {
  std::ifstream stream(path, std::ios::binary);
  if (!stream) G6D_THROW("cannot open " << path.string());
  std::ostringstream text;
  text << stream.rdbuf();
  if (stream.bad()) G6D_THROW("cannot read " << path.string());
  return text.str();
}

Json ParseJson(const std::string& text, const std::string& source) {
  try {
    return Json::parse(text);
  } catch (const Json::exception& e) {
    G6D_THROW("malformed JSON in " << source << ": " << e.what());
  }
}

Json ReadJson(const fs::path& path) { return ParseJson(ReadText(path), path.string()); }

// A place in a JSON file for error messages: "<file>: <field path>".
struct Where {
  std::string file;
  std::string field;

  Where Key(const std::string& key) const {
    return {file, field.empty() ? key : field + "." + key};
  }
  Where Index(size_t index) const { return {file, field + "[" + std::to_string(index) + "]"}; }
};

std::ostream& operator<<(std::ostream& out, const Where& where) {
  out << where.file;
  if (!where.field.empty()) out << ": field '" << where.field << "'";
  return out;
}

const char* TypeName(const Json& value) { return value.type_name(); }

// A JSON value for an error message: its type and, for a scalar, its text (strings cut
// after 40 bytes). Never the dump of a list or object: a message must not grow with the
// input, and dump() recurses once per nesting level, so a deeply nested value (which
// the parser accepts, it does not recurse) would overflow the stack.
std::string Describe(const Json& value) {
  constexpr size_t kMaxStringBytes = 40;
  // replace: a string cut inside a UTF-8 sequence must not make dump() throw.
  const auto dump = [](const Json& v) {
    return v.dump(-1, ' ', false, Json::error_handler_t::replace);
  };
  if (value.is_array()) return "a list of " + std::to_string(value.size()) + " elements";
  if (value.is_object()) return "an object of " + std::to_string(value.size()) + " members";
  if (value.is_string()) {
    const std::string& text = value.get_ref<const std::string&>();
    if (text.size() > kMaxStringBytes) {
      return "string " + dump(Json(text.substr(0, kMaxStringBytes))) + "... (" +
             std::to_string(text.size()) + " bytes)";
    }
  }
  return std::string(TypeName(value)) + " " + dump(value);
}

void ExpectObject(const Json& value, const Where& where) {
  if (!value.is_object()) G6D_THROW(where << ": expected a JSON object, got " << TypeName(value));
}

const Json& Member(const Json& object, const std::string& key, const Where& where) {
  ExpectObject(object, where);
  const auto it = object.find(key);
  if (it == object.end()) G6D_THROW(where.Key(key) << " is missing");
  return *it;
}

double GetNumber(const Json& value, const Where& where) {
  if (!value.is_number()) G6D_THROW(where << ": expected a number, got " << TypeName(value));
  const double number = value.get<double>();
  if (!std::isfinite(number)) G6D_THROW(where << ": expected a finite number, got " << number);
  return number;
}

int GetInt(const Json& value, const Where& where) {
  if (!value.is_number_integer())
    G6D_THROW(where << ": expected an integer, got " << Describe(value));
  // get<int>() would silently wrap a value outside int (2^32 + 5 -> 5).
  const bool in_range =
      value.is_number_unsigned()
          ? value.get<uint64_t>() <= static_cast<uint64_t>(std::numeric_limits<int>::max())
          : value.get<int64_t>() >= std::numeric_limits<int>::min() &&
                value.get<int64_t>() <= std::numeric_limits<int>::max();
  if (!in_range) {
    G6D_THROW(where << ": integer " << Describe(value) << " is out of range (expected "
                    << std::numeric_limits<int>::min() << ".." << std::numeric_limits<int>::max()
                    << ")");
  }
  return value.get<int>();
}

// A list of exactly `count` numbers.
std::vector<double> GetNumbers(const Json& value, size_t count, const Where& where) {
  if (!value.is_array() || value.size() != count) {
    G6D_THROW(where << ": expected a list of " << count << " numbers, got "
                    << (value.is_array() ? std::to_string(value.size()) + " elements"
                                         : std::string(TypeName(value))));
  }
  std::vector<double> numbers(count);
  for (size_t i = 0; i < count; ++i) numbers[i] = GetNumber(value[i], where.Index(i));
  return numbers;
}

// "8" -> 8 for the image-id keys of scene_*.json and obj-id keys of models_info.json.
int ParseIdKey(const std::string& key, const Where& where) {
  const bool digits =
      !key.empty() && key.size() <= 9 &&
      std::all_of(key.begin(), key.end(), [](unsigned char c) { return std::isdigit(c) != 0; });
  if (!digits) G6D_THROW(where << ": key '" << key << "' is not a non-negative integer id");
  return std::stoi(key);
}

Camera CameraFromK(const std::vector<double>& k_row_major) {
  Camera camera;
  camera.fx = k_row_major[0];
  camera.fy = k_row_major[4];
  camera.cx = k_row_major[2];
  camera.cy = k_row_major[5];
  return camera;
}

BopObjectInfo ParseObjectInfo(int obj_id, const Json& entry, const fs::path& models_dir,
                              const Where& where) {
  ExpectObject(entry, where);
  BopObjectInfo info;
  info.obj_id = obj_id;
  info.name = BopObjectName(obj_id);
  info.diameter_m =
      GetNumber(Member(entry, "diameter", where), where.Key("diameter")) * kMetresPerMillimetre;
  if (!(info.diameter_m > 0.0)) {
    G6D_THROW(where.Key("diameter") << ": expected a positive diameter (mm), got "
                                    << info.diameter_m / kMetresPerMillimetre);
  }
  const char* kMin[3] = {"min_x", "min_y", "min_z"};
  const char* kSize[3] = {"size_x", "size_y", "size_z"};
  bool has_box = true;
  for (int a = 0; a < 3; ++a)
    has_box = has_box && entry.contains(kMin[a]) && entry.contains(kSize[a]);
  if (has_box) {
    Eigen::Vector3d min_m, size_m;
    for (int a = 0; a < 3; ++a) {
      min_m[a] = GetNumber(entry[kMin[a]], where.Key(kMin[a])) * kMetresPerMillimetre;
      size_m[a] = GetNumber(entry[kSize[a]], where.Key(kSize[a])) * kMetresPerMillimetre;
    }
    info.box_m = Eigen::AlignedBox3d(min_m, min_m + size_m);
  }

  // g6d extension (ycbv_real): "mesh" relative to models/, "units" of that file.
  std::string mesh = info.name + ".ply";
  if (entry.contains("mesh")) {
    const Json& value = entry["mesh"];
    if (!value.is_string() || value.get<std::string>().empty()) {
      G6D_THROW(where.Key("mesh") << ": expected a non-empty path string, got " << Describe(value));
    }
    mesh = value.get<std::string>();
  }
  info.mesh_path = (models_dir / mesh).string();
  if (entry.contains("units")) {
    const Json& value = entry["units"];
    if (!value.is_string()) {
      G6D_THROW(where.Key("units") << ": expected \"mm\" or \"m\", got " << Describe(value));
    }
    try {
      info.mesh_units = ParseUnits(value.get<std::string>());
    } catch (const Error& e) {
      G6D_THROW(where.Key("units") << ": " << e.what());
    }
  }

  if (entry.contains("symmetries_discrete")) {
    const Where list_where = where.Key("symmetries_discrete");
    const Json& list = entry["symmetries_discrete"];
    if (!list.is_array()) G6D_THROW(list_where << ": expected a list, got " << TypeName(list));
    for (size_t s = 0; s < list.size(); ++s) {
      const std::vector<double> m = GetNumbers(list[s], 16, list_where.Index(s));
      Eigen::Isometry3d symmetry = Eigen::Isometry3d::Identity();
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) symmetry.linear()(r, c) = m[4 * r + c];
        symmetry.translation()[r] = m[4 * r + 3] * kMetresPerMillimetre;
      }
      info.symmetries_discrete.push_back(symmetry);
    }
  }
  if (entry.contains("symmetries_continuous")) {
    const Where list_where = where.Key("symmetries_continuous");
    const Json& list = entry["symmetries_continuous"];
    if (!list.is_array()) G6D_THROW(list_where << ": expected a list, got " << TypeName(list));
    for (size_t s = 0; s < list.size(); ++s) {
      const Where item = list_where.Index(s);
      const std::vector<double> axis =
          GetNumbers(Member(list[s], "axis", item), 3, item.Key("axis"));
      const std::vector<double> offset =
          GetNumbers(Member(list[s], "offset", item), 3, item.Key("offset"));
      ContinuousSymmetry symmetry;
      symmetry.axis = Eigen::Vector3d(axis[0], axis[1], axis[2]);
      if (symmetry.axis.norm() == 0.0) G6D_THROW(item.Key("axis") << ": axis is zero");
      symmetry.offset_m = Eigen::Vector3d(offset[0], offset[1], offset[2]) * kMetresPerMillimetre;
      info.symmetries_continuous.push_back(symmetry);
    }
  }
  return info;
}

// Width and height for a scene without camera.json: from its first RGB or depth image.
bool ImageSizeFromScene(const fs::path& scene_dir, int* width, int* height) {
  for (const char* sub : {"rgb", "depth"}) {
    const fs::path dir = scene_dir / sub;
    if (!fs::is_directory(dir)) continue;
    std::vector<fs::path> files;
    for (const auto& item : fs::directory_iterator(dir)) {
      if (item.is_regular_file()) files.push_back(item.path());
    }
    std::sort(files.begin(), files.end());
    for (const fs::path& file : files) {
      const cv::Mat image = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
      if (image.empty()) continue;
      *width = image.cols;
      *height = image.rows;
      return true;
    }
  }
  return false;
}

BopGtInfo ParseGtInfo(const Json& entry, const Where& where) {
  ExpectObject(entry, where);
  BopGtInfo info;
  auto box = [&](const char* key, std::array<int, 4>* out) {
    if (!entry.contains(key)) return;
    const Where field = where.Key(key);
    const Json& list = entry[key];
    if (!list.is_array() || list.size() != 4) {
      G6D_THROW(field << ": expected a list of 4 integers, got " << Describe(list));
    }
    for (int i = 0; i < 4; ++i) (*out)[i] = GetInt(list[i], field.Index(i));
  };
  box("bbox_obj", &info.bbox_obj);
  box("bbox_visib", &info.bbox_visib);
  auto count = [&](const char* key, int* out) {
    if (entry.contains(key)) *out = GetInt(entry[key], where.Key(key));
  };
  count("px_count_all", &info.px_count_all);
  count("px_count_valid", &info.px_count_valid);
  count("px_count_visib", &info.px_count_visib);
  if (entry.contains("visib_fract")) {
    info.visib_fract = GetNumber(entry["visib_fract"], where.Key("visib_fract"));
  }
  return info;
}

cv::Mat ReadImage(const fs::path& path, int flags) {
  if (!fs::is_regular_file(path)) G6D_THROW("image " << path.string() << " does not exist");
  cv::Mat image = cv::imread(path.string(), flags);
  if (image.empty()) G6D_THROW("cannot read image " << path.string());
  return image;
}

cv::Mat ReadMask(const BopScene& scene, const char* folder, int im_id, int gt_idx) {
  const BopFrame& frame = scene.Frame(im_id);
  if (gt_idx < 0 || gt_idx >= static_cast<int>(frame.gt.size())) {
    G6D_THROW("scene " << scene.scene_id << " image " << im_id << ": gt_idx " << gt_idx
                       << " out of range (the frame has " << frame.gt.size() << " GT instances)");
  }
  const fs::path path =
      fs::path(scene.directory) / folder / (SixDigits(im_id) + "_" + SixDigits(gt_idx) + ".png");
  cv::Mat mask = ReadImage(path, cv::IMREAD_UNCHANGED);
  if (mask.type() != CV_8UC1) {
    G6D_THROW("mask " << path.string() << ": expected 8-bit single channel, got " << mask.channels()
                      << " channels of depth " << mask.depth());
  }
  return mask;
}

}  // namespace

std::string BopObjectName(int obj_id) {
  if (obj_id < 0 || obj_id > 999999) {
    G6D_THROW("BopObjectName: obj_id must be in 0..999999 (got " << obj_id << ")");
  }
  return "obj_" + SixDigits(obj_id);
}

int ParseBopObjectName(const std::string& name) {
  const bool ok = name.size() == 10 && name.compare(0, 4, "obj_") == 0 &&
                  std::all_of(name.begin() + 4, name.end(),
                              [](unsigned char c) { return std::isdigit(c) != 0; });
  if (!ok) G6D_THROW("'" << name << "' is not a BOP object name (expected obj_ + 6 digits)");
  return std::stoi(name.substr(4));
}

const BopObjectInfo& BopDataset::Object(int obj_id) const {
  const auto it = objects.find(obj_id);
  if (it == objects.end()) {
    G6D_THROW("object " << obj_id << " is not in " << root << "/models/models_info.json");
  }
  return it->second;
}

std::vector<BopTarget> ParseBopTargets(const std::string& json_text, const std::string& source) {
  const Json json = ParseJson(json_text, source);
  const Where where{source, ""};
  if (!json.is_array()) G6D_THROW(where << ": expected a list, got " << TypeName(json));
  std::vector<BopTarget> targets;
  targets.reserve(json.size());
  for (size_t i = 0; i < json.size(); ++i) {
    const Where item{source, "[" + std::to_string(i) + "]"};
    BopTarget target;
    target.scene_id = GetInt(Member(json[i], "scene_id", item), item.Key("scene_id"));
    target.im_id = GetInt(Member(json[i], "im_id", item), item.Key("im_id"));
    target.obj_id = GetInt(Member(json[i], "obj_id", item), item.Key("obj_id"));
    target.inst_count = GetInt(Member(json[i], "inst_count", item), item.Key("inst_count"));
    targets.push_back(target);
  }
  return targets;
}

std::vector<BopTarget> LoadBopTargets(const std::string& path) {
  if (!fs::exists(path)) G6D_THROW("BOP targets file " << path << " does not exist");
  return ParseBopTargets(ReadText(path), path);
}

BopCameraInfo ParseBopCamera(const std::string& json_text, const std::string& source) {
  const Json json = ParseJson(json_text, source);
  const Where where{source, ""};
  BopCameraInfo info;
  Camera& camera = info.camera;
  camera.fx = GetNumber(Member(json, "fx", where), where.Key("fx"));
  camera.fy = GetNumber(Member(json, "fy", where), where.Key("fy"));
  camera.cx = GetNumber(Member(json, "cx", where), where.Key("cx"));
  camera.cy = GetNumber(Member(json, "cy", where), where.Key("cy"));
  camera.width = GetInt(Member(json, "width", where), where.Key("width"));
  camera.height = GetInt(Member(json, "height", where), where.Key("height"));
  const std::string problem = camera.Check();
  if (!problem.empty()) G6D_THROW(source << ": " << problem);
  if (json.contains("depth_scale")) {
    info.depth_scale = GetNumber(json["depth_scale"], where.Key("depth_scale"));
  }
  return info;
}

std::map<int, BopObjectInfo> ParseBopModelsInfo(const std::string& json_text,
                                                const std::string& source,
                                                const std::string& models_dir) {
  const Json info_json = ParseJson(json_text, source);
  ExpectObject(info_json, {source, ""});
  std::map<int, BopObjectInfo> objects;
  for (const auto& [key, entry] : info_json.items()) {
    const Where where{source, key};
    const int obj_id = ParseIdKey(key, {source, ""});
    objects.emplace(obj_id, ParseObjectInfo(obj_id, entry, models_dir, where));
  }
  return objects;
}

BopDataset LoadBopDataset(const std::string& root, const std::string& split) {
  const fs::path root_path(root);
  if (!fs::is_directory(root_path)) G6D_THROW("BOP dataset root " << root << " is not a folder");
  BopDataset dataset;
  dataset.root = root;
  dataset.split = split;

  const fs::path camera_path = root_path / "camera.json";
  if (fs::exists(camera_path)) {
    const BopCameraInfo info = ParseBopCamera(ReadText(camera_path), camera_path.string());
    dataset.camera = info.camera;
    dataset.camera_depth_scale = info.depth_scale;
  }

  const fs::path models_dir = root_path / "models";
  const fs::path info_path = models_dir / "models_info.json";
  if (!fs::exists(info_path))
    G6D_THROW("BOP dataset " << root << ": " << info_path.string() << " is missing");
  dataset.objects =
      ParseBopModelsInfo(ReadText(info_path), info_path.string(), models_dir.string());

  const fs::path targets_path = root_path / "test_targets_bop19.json";
  if (fs::exists(targets_path)) {
    dataset.has_targets = true;
    dataset.targets = LoadBopTargets(targets_path.string());
  }

  const fs::path split_dir = root_path / split;
  if (fs::is_directory(split_dir)) {
    for (const auto& item : fs::directory_iterator(split_dir)) {
      const std::string name = item.path().filename().string();
      const bool digits = !name.empty() && name.size() <= 9 &&
                          std::all_of(name.begin(), name.end(),
                                      [](unsigned char c) { return std::isdigit(c) != 0; });
      if (item.is_directory() && digits) dataset.scene_ids.push_back(std::stoi(name));
    }
    std::sort(dataset.scene_ids.begin(), dataset.scene_ids.end());
  }
  return dataset;
}

std::vector<int> TargetGtIndices(const BopFrame& frame, int obj_id, int inst_count) {
  std::vector<int> of_object;
  for (size_t g = 0; g < frame.gt.size(); ++g) {
    if (frame.gt[g].obj_id == obj_id) of_object.push_back(static_cast<int>(g));
  }
  auto visib = [&](int g) { return frame.gt[g].info ? frame.gt[g].info->visib_fract : 1.0; };
  std::stable_sort(of_object.begin(), of_object.end(), [&](int a, int b) { return visib(a) > visib(b); });
  of_object.resize(std::min<size_t>(of_object.size(), static_cast<size_t>(std::max(0, inst_count))));
  std::sort(of_object.begin(), of_object.end());
  return of_object;
}

const BopFrame& BopScene::Frame(int im_id) const {
  const auto it = std::lower_bound(frames.begin(), frames.end(), im_id,
                                   [](const BopFrame& f, int id) { return f.im_id < id; });
  if (it == frames.end() || it->im_id != im_id) {
    G6D_THROW("image " << im_id << " is not in scene " << directory << "/scene_gt.json");
  }
  return *it;
}

int BopScene::InstanceCount() const {
  int count = 0;
  for (const BopFrame& frame : frames) count += static_cast<int>(frame.gt.size());
  return count;
}

BopScene LoadBopScene(const std::string& root, int scene_id, const std::string& split) {
  const fs::path scene_dir = fs::path(root) / split / SixDigits(scene_id);
  if (!fs::is_directory(scene_dir)) {
    G6D_THROW("BOP scene folder " << scene_dir.string() << " does not exist");
  }
  BopScene scene;
  scene.root = root;
  scene.directory = scene_dir.string();
  scene.scene_id = scene_id;

  // Image size: camera.json at the root, else the scene's first image.
  int width = 0, height = 0;
  const fs::path camera_path = fs::path(root) / "camera.json";
  if (fs::exists(camera_path)) {
    const Json json = ReadJson(camera_path);
    const Where where{camera_path.string(), ""};
    width = GetInt(Member(json, "width", where), where.Key("width"));
    height = GetInt(Member(json, "height", where), where.Key("height"));
  } else {
    ImageSizeFromScene(scene_dir, &width, &height);
  }

  const fs::path camera_file = scene_dir / "scene_camera.json";
  const fs::path gt_file = scene_dir / "scene_gt.json";
  const fs::path info_file = scene_dir / "scene_gt_info.json";
  for (const fs::path& required : {camera_file, gt_file}) {
    if (!fs::exists(required)) G6D_THROW("BOP scene file " << required.string() << " is missing");
  }
  const std::string camera_text = ReadText(camera_file);
  const std::string gt_text = ReadText(gt_file);
  std::optional<std::string> info_text;
  if (fs::exists(info_file)) info_text = ReadText(info_file);
  scene.frames = ParseBopSceneFrames(camera_text, gt_text, info_text, width, height,
                                     {camera_file.string(), gt_file.string(), info_file.string()});
  return scene;
}

std::vector<BopFrame> ParseBopSceneFrames(const std::string& camera_json_text,
                                          const std::string& gt_json_text,
                                          const std::optional<std::string>& gt_info_json_text,
                                          int width, int height, const BopSceneSources& sources) {
  const Json camera_json = ParseJson(camera_json_text, sources.camera);
  ExpectObject(camera_json, {sources.camera, ""});
  std::map<int, BopFrame> frames;
  for (const auto& [key, entry] : camera_json.items()) {
    const Where where{sources.camera, key};
    BopFrame frame;
    frame.im_id = ParseIdKey(key, {sources.camera, ""});
    frame.camera = CameraFromK(GetNumbers(Member(entry, "cam_K", where), 9, where.Key("cam_K")));
    frame.camera.width = width;
    frame.camera.height = height;
    if (entry.contains("depth_scale")) {
      frame.depth_scale = GetNumber(entry["depth_scale"], where.Key("depth_scale"));
      if (!(frame.depth_scale > 0.0)) {
        G6D_THROW(where.Key("depth_scale")
                  << ": expected a positive number, got " << frame.depth_scale);
      }
    }
    frames.emplace(frame.im_id, std::move(frame));
  }

  const Json gt_json = ParseJson(gt_json_text, sources.gt);
  ExpectObject(gt_json, {sources.gt, ""});
  for (const auto& [key, list] : gt_json.items()) {
    const Where where{sources.gt, key};
    const int im_id = ParseIdKey(key, {sources.gt, ""});
    const auto frame_it = frames.find(im_id);
    if (frame_it == frames.end()) {
      G6D_THROW(where << ": image " << im_id << " has no entry in " << sources.camera);
    }
    if (!list.is_array()) G6D_THROW(where << ": expected a list, got " << TypeName(list));
    for (size_t i = 0; i < list.size(); ++i) {
      const Where item = where.Index(i);
      BopGtInstance gt;
      gt.obj_id = GetInt(Member(list[i], "obj_id", item), item.Key("obj_id"));
      const std::vector<double> r =
          GetNumbers(Member(list[i], "cam_R_m2c", item), 9, item.Key("cam_R_m2c"));
      const std::vector<double> t =
          GetNumbers(Member(list[i], "cam_t_m2c", item), 3, item.Key("cam_t_m2c"));
      for (int row = 0; row < 3; ++row) {
        for (int col = 0; col < 3; ++col) gt.cam_from_object.linear()(row, col) = r[3 * row + col];
        gt.cam_from_object.translation()[row] = t[row] * kMetresPerMillimetre;
      }
      frame_it->second.gt.push_back(gt);
    }
  }

  if (gt_info_json_text) {
    const Json info_json = ParseJson(*gt_info_json_text, sources.gt_info);
    ExpectObject(info_json, {sources.gt_info, ""});
    for (const auto& [key, list] : info_json.items()) {
      const Where where{sources.gt_info, key};
      const int im_id = ParseIdKey(key, {sources.gt_info, ""});
      const auto frame_it = frames.find(im_id);
      const size_t expected = frame_it == frames.end() ? 0 : frame_it->second.gt.size();
      if (!list.is_array() || list.size() != expected) {
        G6D_THROW(where << ": expected a list of " << expected
                        << " entries (as in scene_gt.json), got "
                        << (list.is_array() ? std::to_string(list.size()) + " entries"
                                            : std::string(TypeName(list))));
      }
      for (size_t i = 0; i < list.size(); ++i) {
        frame_it->second.gt[i].info = ParseGtInfo(list[i], where.Index(i));
      }
    }
  }

  // Every image of scene_camera.json is a frame; one without scene_gt.json entry (BOP
  // allows that) keeps an empty GT list.
  std::vector<BopFrame> sorted;
  sorted.reserve(frames.size());
  for (auto& [im_id, frame] : frames) sorted.push_back(std::move(frame));
  return sorted;
}

cv::Mat LoadBopRgb(const BopScene& scene, int im_id) {
  const fs::path base = fs::path(scene.directory) / "rgb" / SixDigits(im_id);
  fs::path path = base;
  path += ".png";
  if (!fs::exists(path)) {
    fs::path jpg = base;
    jpg += ".jpg";
    if (!fs::exists(jpg)) {
      G6D_THROW("RGB image " << path.string() << " (or .jpg) does not exist");
    }
    path = jpg;
  }
  const cv::Mat bgr = ReadImage(path, cv::IMREAD_COLOR);
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  return rgb;
}

cv::Mat LoadBopDepth(const BopScene& scene, int im_id, const std::string& folder) {
  const BopFrame& frame = scene.Frame(im_id);
  const fs::path path = fs::path(scene.directory) / folder / (SixDigits(im_id) + ".png");
  const cv::Mat raw = ReadImage(path, cv::IMREAD_UNCHANGED);
  if (raw.type() != CV_16UC1) {
    G6D_THROW("depth image " << path.string() << ": expected 16-bit single channel, got "
                             << raw.channels() << " channels of OpenCV depth " << raw.depth());
  }
  cv::Mat depth_m;
  raw.convertTo(depth_m, CV_32F, frame.depth_scale * kMetresPerMillimetre);
  return depth_m;
}

cv::Mat LoadBopMaskVisib(const BopScene& scene, int im_id, int gt_idx) {
  return ReadMask(scene, "mask_visib", im_id, gt_idx);
}

cv::Mat LoadBopMask(const BopScene& scene, int im_id, int gt_idx) {
  return ReadMask(scene, "mask", im_id, gt_idx);
}

}  // namespace g6d
