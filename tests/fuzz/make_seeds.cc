// g6d-fuzz-make-seeds: regenerates the committed seed corpora tests/fuzz/corpus/<name>/ of
// the fuzz targets, deterministically, with the project's own encoders (EncodeImage, the
// LCM encoder, WriteTemplateCache, WriteBopCsv) and BOP JSON written by hand. Each target
// gets a handful of small valid inputs plus near misses (truncated, a wrong checksum or
// field, one value out of range), so that fuzzing starts next to the interesting checks.
//
// Usage: g6d-fuzz-make-seeds [FUZZ_DIR]
// FUZZ_DIR defaults to the source tree's tests/fuzz. Each corpus/<name>/ folder is
// replaced as a whole; regressions/ is never touched.
#include <unistd.h>
#include <zstd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "bot_core/images_t.hpp"
#include "core/error.h"
#include "drake/lcmt_image_array.hpp"
#include "eval/bop_csv.h"
#include "g6d/rgbd_frame_t.hpp"
#include "wire/foreign_images.h"
#include "wire/frame_codec.h"
#include "templates/cache.h"
#include "test_meshes.h"

namespace g6d {
namespace {

namespace fs = std::filesystem;

// Tiny planes: every seed stays a few KB.
constexpr int kWidth = 32;
constexpr int kHeight = 24;

// ---- Output ---------------------------------------------------------------------------

// One corpus folder, emptied on construction.
class Corpus {
 public:
  Corpus(const fs::path& fuzz_dir, const std::string& target)
      : directory_(fuzz_dir / "corpus" / target) {
    fs::remove_all(directory_);
    fs::create_directories(directory_);
  }
  void Add(const std::string& name, const std::string& bytes) {
    std::ofstream out(directory_ / name, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!out) G6D_THROW("cannot write " << (directory_ / name).string());
    ++count_;
    bytes_ += bytes.size();
  }
  void Add(const std::string& name, const std::vector<uint8_t>& bytes) {
    Add(name, std::string(bytes.begin(), bytes.end()));
  }
  void Report() const {
    std::printf("%-40s %3d files %7zu bytes\n", directory_.string().c_str(), count_, bytes_);
  }

 private:
  fs::path directory_;
  int count_ = 0;
  size_t bytes_ = 0;
};

// ---- Images ---------------------------------------------------------------------------

struct PlaneKind {
  int8_t format;
  int8_t compression;
};

std::string Lower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

std::string KindName(const PlaneKind& kind) {
  return Lower(PixelFormatName(kind.format)) + "_" + Lower(CompressionName(kind.compression));
}

// Every pixel format with every compression that can carry it (frame_codec.h).
std::vector<PlaneKind> AllPlaneKinds() {
  std::vector<PlaneKind> kinds;
  for (int8_t format : {image_t::FORMAT_RGB8, image_t::FORMAT_BGR8, image_t::FORMAT_MONO8,
                        image_t::FORMAT_DEPTH_U16, image_t::FORMAT_DEPTH_F32,
                        image_t::FORMAT_LABEL_U8, image_t::FORMAT_LABEL_U16}) {
    for (int8_t compression : {image_t::COMPRESSION_NONE, image_t::COMPRESSION_ZSTD,
                               image_t::COMPRESSION_PNG, image_t::COMPRESSION_JPEG}) {
      const bool colour = format == image_t::FORMAT_RGB8 || format == image_t::FORMAT_BGR8 ||
                          format == image_t::FORMAT_MONO8;
      if (compression == image_t::COMPRESSION_JPEG && !colour) continue;
      if (compression == image_t::COMPRESSION_PNG && format == image_t::FORMAT_DEPTH_F32) continue;
      kinds.push_back({format, compression});
    }
  }
  return kinds;
}

// A smooth test plane of `format`: colour gradients, depth 0.5-0.9 m (millimetres for
// DEPTH_U16; one NaN and one negative value for DEPTH_F32, which decode to 0), labels
// 0 with two rectangles (1 and 2; 1 and 300 for LABEL_U16).
cv::Mat MakePlane(int8_t format) {
  cv::Mat plane(kHeight, kWidth, OpenCvTypeOf(format));
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const double depth_m = 0.5 + 0.01 * u + 0.005 * v;
      const int label = (u >= 4 && u < 14 && v >= 4 && v < 12)    ? 1
                        : (u >= 18 && u < 28 && v >= 8 && v < 20) ? 2
                                                                  : 0;
      switch (format) {
        case image_t::FORMAT_RGB8:
        case image_t::FORMAT_BGR8:
          plane.at<cv::Vec3b>(v, u) =
              cv::Vec3b(static_cast<uint8_t>(8 * u), static_cast<uint8_t>(10 * v), 128);
          break;
        case image_t::FORMAT_MONO8:
          plane.at<uint8_t>(v, u) = static_cast<uint8_t>(4 * u + 5 * v);
          break;
        case image_t::FORMAT_DEPTH_U16:
          plane.at<uint16_t>(v, u) = static_cast<uint16_t>(std::lround(1000.0 * depth_m));
          break;
        case image_t::FORMAT_DEPTH_F32:
          plane.at<float>(v, u) = static_cast<float>(depth_m);
          break;
        case image_t::FORMAT_LABEL_U8:
          plane.at<uint8_t>(v, u) = static_cast<uint8_t>(label);
          break;
        case image_t::FORMAT_LABEL_U16:
          plane.at<uint16_t>(v, u) = static_cast<uint16_t>(label == 2 ? 300 : label);
          break;
      }
    }
  }
  if (format == image_t::FORMAT_DEPTH_F32) {
    plane.at<float>(0, 0) = std::numeric_limits<float>::quiet_NaN();
    plane.at<float>(1, 0) = -1.0f;
  }
  return plane;
}

// The second label value of MakePlane(format).
int32_t SecondLabel(int8_t format) { return format == image_t::FORMAT_LABEL_U16 ? 300 : 2; }

// `image` (COMPRESSION_NONE) with rows padded by `padding` bytes.
image_t PadRows(const image_t& image, int padding) {
  image_t padded = image;
  const int row_bytes = image.row_stride;
  padded.row_stride = row_bytes + padding;
  padded.data.assign(static_cast<size_t>(padded.row_stride) * image.height, 0xAB);
  for (int v = 0; v < image.height; ++v) {
    std::memcpy(padded.data.data() + static_cast<size_t>(v) * padded.row_stride,
                image.data.data() + static_cast<size_t>(v) * row_bytes, row_bytes);
  }
  padded.size = static_cast<int32_t>(padded.data.size());
  return padded;
}

// `raw` (a padded COMPRESSION_NONE plane) as one zstd frame with its content size.
image_t ZstdOf(const image_t& raw) {
  image_t packed = raw;
  packed.compression = image_t::COMPRESSION_ZSTD;
  packed.data.resize(ZSTD_compressBound(raw.data.size()));
  const size_t size =
      ZSTD_compress(packed.data.data(), packed.data.size(), raw.data.data(), raw.data.size(), 1);
  if (ZSTD_isError(size)) G6D_THROW("zstd: " << ZSTD_getErrorName(size));
  packed.data.resize(size);
  packed.size = static_cast<int32_t>(size);
  return packed;
}

// ---- frame_message --------------------------------------------------------------------

rgbd_frame_t MakeFrame(const PlaneKind& color, const PlaneKind& depth, const PlaneKind& labels) {
  rgbd_frame_t frame;
  frame.utime = 1700000000000000;  // fixed: seeds must not depend on the clock
  frame.seq = 42;
  frame.camera_id = "cam0";
  frame.source = "g6d-fuzz-make-seeds";
  frame.scene_id = 2;
  frame.image_id = 8;
  frame.fx = 40.0;
  frame.fy = 40.5;
  frame.cx = 15.5;
  frame.cy = 11.5;
  frame.depth_scale_m = 0.001;
  frame.color = EncodeImage(MakePlane(color.format), color.format, color.compression);
  frame.depth = EncodeImage(MakePlane(depth.format), depth.format, depth.compression);
  frame.labels = EncodeImage(MakePlane(labels.format), labels.format, labels.compression);
  for (const auto& [object_id, label] : {std::pair<const char*, int32_t>{"obj_000001", 1},
                                         {"obj_000005", SecondLabel(labels.format)}}) {
    instance_t instance{};  // {}: no box, no candidates (lcm-gen leaves members uninitialized)
    instance.object_id = object_id;
    instance.label = label;
    instance.score = 0.9f;
    instance.gt_index = label == 1 ? 0 : 1;
    frame.instances.push_back(instance);
  }
  frame.num_instances = static_cast<int32_t>(frame.instances.size());
  return frame;
}

std::string Encode(const rgbd_frame_t& frame) {
  std::string bytes(static_cast<size_t>(frame.getEncodedSize()), '\0');
  if (frame.encode(bytes.data(), 0, static_cast<int>(bytes.size())) < 0)
    G6D_THROW("rgbd_frame_t::encode failed");
  return bytes;
}

void MakeFrameSeeds(const fs::path& fuzz_dir) {
  Corpus corpus(fuzz_dir, "frame_message");
  std::vector<PlaneKind> colors, depths, labels;
  for (const PlaneKind& kind : AllPlaneKinds()) {
    switch (kind.format) {
      case image_t::FORMAT_RGB8:
      case image_t::FORMAT_BGR8:
      case image_t::FORMAT_MONO8:
        colors.push_back(kind);
        break;
      case image_t::FORMAT_DEPTH_U16:
      case image_t::FORMAT_DEPTH_F32:
        depths.push_back(kind);
        break;
      default:
        labels.push_back(kind);
    }
  }
  // Every colour kind once; depth and label kinds cycle, so each appears at least twice.
  for (size_t i = 0; i < colors.size(); ++i) {
    const PlaneKind& depth = depths[i % depths.size()];
    const PlaneKind& label = labels[i % labels.size()];
    corpus.Add("valid_" + KindName(colors[i]) + "_" + KindName(depth) + "_" + KindName(label),
               Encode(MakeFrame(colors[i], depth, label)));
  }
  const PlaneKind rgb_none{image_t::FORMAT_RGB8, image_t::COMPRESSION_NONE};
  const PlaneKind depth_zstd{image_t::FORMAT_DEPTH_U16, image_t::COMPRESSION_ZSTD};
  const PlaneKind labels_zstd{image_t::FORMAT_LABEL_U8, image_t::COMPRESSION_ZSTD};
  const rgbd_frame_t base = MakeFrame(rgb_none, depth_zstd, labels_zstd);
  const std::string base_bytes = Encode(base);

  rgbd_frame_t padded = base;
  padded.color = PadRows(base.color, 4);
  corpus.Add("valid_padded_row_stride", Encode(padded));

  rgbd_frame_t no_pixels = base;
  no_pixels.instances[1].label = 7;  // label 2 is then named by no instance
  corpus.Add("near_label_named_by_no_instance", Encode(no_pixels));
  rgbd_frame_t extra = base;
  instance_t missing = base.instances[0];
  missing.object_id = "obj_000009";
  missing.label = 9;  // a label without pixels: an instance error, the frame is fine
  extra.instances.push_back(missing);
  extra.num_instances = 3;
  corpus.Add("valid_instance_label_without_pixels", Encode(extra));

  // Where the object is and which it is (instance_t's box and candidate_ids): a box with
  // no label image at all, an instance of unknown identity with candidates, and near
  // misses (a box outside the image, an empty candidate id).
  rgbd_frame_t boxes = base;
  boxes.labels = image_t{};  // 0 x 0: no label image
  boxes.labels.pixel_format = image_t::FORMAT_LABEL_U8;
  for (instance_t& instance : boxes.instances) {
    instance.label = 0;
    const int32_t box[4] = {instance.gt_index == 0 ? 2 : 20, 3, 9, 7};
    std::copy(box, box + 4, instance.box);
  }
  boxes.instances[1].object_id.clear();
  boxes.instances[1].candidate_ids = {"obj_000001", "obj_000005"};
  boxes.instances[1].num_candidate_ids = 2;
  corpus.Add("valid_boxes_no_label_image_unknown_identity", Encode(boxes));
  rgbd_frame_t unknown = base;
  unknown.instances[0].object_id.clear();
  corpus.Add("valid_label_unknown_identity_every_object", Encode(unknown));
  rgbd_frame_t outside = boxes;
  outside.instances[0].box[0] = kWidth + 3;
  corpus.Add("near_box_outside_the_image", Encode(outside));
  rgbd_frame_t empty_candidate = boxes;
  empty_candidate.instances[1].candidate_ids[1].clear();
  corpus.Add("near_empty_candidate_id", Encode(empty_candidate));

  // Neither mask nor box (instance_t's count): detection requests, one of an object and
  // one over candidates, with no label image.
  rgbd_frame_t detect = boxes;
  for (instance_t& instance : detect.instances) {
    std::fill(instance.box, instance.box + 4, 0);
    instance.count = 2;
  }
  corpus.Add("valid_detection_requests_no_label_image", Encode(detect));

  rgbd_frame_t zero_fx = base;
  zero_fx.fx = 0.0;
  corpus.Add("near_zero_fx", Encode(zero_fx));
  rgbd_frame_t small_depth = base;
  cv::Mat depth_small;
  cv::resize(MakePlane(image_t::FORMAT_DEPTH_U16), depth_small, cv::Size(16, 12), 0, 0,
             cv::INTER_NEAREST);
  small_depth.depth =
      EncodeImage(depth_small, image_t::FORMAT_DEPTH_U16, image_t::COMPRESSION_ZSTD);
  corpus.Add("near_depth_size_differs", Encode(small_depth));
  rgbd_frame_t corrupt = base;
  corrupt.depth.data[corrupt.depth.data.size() / 2] ^= 0x5A;
  corpus.Add("near_corrupted_depth_zstd", Encode(corrupt));

  corpus.Add("near_truncated", base_bytes.substr(0, base_bytes.size() / 2));
  std::string fingerprint = base_bytes;
  fingerprint[7] = static_cast<char>(fingerprint[7] ^ 1);
  corpus.Add("near_bad_fingerprint", fingerprint);
  std::string long_string = base_bytes;  // camera_id length (big-endian int32) at byte 24
  long_string[24] = 0x7f;
  corpus.Add("near_camera_id_length_too_large", long_string);
  corpus.Report();
}

// ---- image_decode ---------------------------------------------------------------------

// The harness's input: a 16-byte header (fuzz_image_decode.cc) then the payload.
std::string ImageInput(const image_t& image, int16_t size_delta = 0) {
  std::string bytes(16, '\0');
  auto store32 = [&](int32_t value, size_t offset) {
    for (int i = 0; i < 4; ++i)
      bytes[offset + i] = static_cast<char>(static_cast<uint32_t>(value) >> (8 * i));
  };
  store32(image.width, 0);
  store32(image.height, 4);
  store32(image.row_stride, 8);
  bytes[12] = static_cast<char>(image.pixel_format);
  bytes[13] = static_cast<char>(image.compression);
  bytes[14] = static_cast<char>(static_cast<uint16_t>(size_delta) & 0xFF);
  bytes[15] = static_cast<char>(static_cast<uint16_t>(size_delta) >> 8);
  bytes.append(image.data.begin(), image.data.end());
  return bytes;
}

void MakeImageSeeds(const fs::path& fuzz_dir) {
  Corpus corpus(fuzz_dir, "image_decode");
  for (const PlaneKind& kind : AllPlaneKinds()) {
    corpus.Add("valid_" + KindName(kind),
               ImageInput(EncodeImage(MakePlane(kind.format), kind.format, kind.compression)));
  }
  const image_t mono = EncodeImage(MakePlane(image_t::FORMAT_MONO8), image_t::FORMAT_MONO8,
                                   image_t::COMPRESSION_NONE);
  const image_t padded = PadRows(mono, 3);
  corpus.Add("valid_mono8_none_padded", ImageInput(padded));
  corpus.Add("valid_mono8_zstd_padded", ImageInput(ZstdOf(padded)));

  corpus.Add("near_size_field_differs", ImageInput(mono, 1));
  image_t narrow_stride = mono;
  narrow_stride.row_stride -= 1;
  corpus.Add("near_row_stride_too_small", ImageInput(narrow_stride));
  image_t png = EncodeImage(MakePlane(image_t::FORMAT_LABEL_U8), image_t::FORMAT_LABEL_U8,
                            image_t::COMPRESSION_PNG);
  png.width += 1;  // the PNG header says 32
  png.row_stride += 1;
  corpus.Add("near_png_size_differs", ImageInput(png));
  image_t jpeg =
      EncodeImage(MakePlane(image_t::FORMAT_RGB8), image_t::FORMAT_RGB8, image_t::COMPRESSION_JPEG);
  jpeg.data.resize(jpeg.data.size() * 2 / 3);
  corpus.Add("near_jpeg_truncated", ImageInput(jpeg));
  image_t zstd = EncodeImage(MakePlane(image_t::FORMAT_DEPTH_F32), image_t::FORMAT_DEPTH_F32,
                             image_t::COMPRESSION_ZSTD);
  zstd.data[zstd.data.size() / 2] ^= 0x33;
  corpus.Add("near_zstd_corrupted", ImageInput(zstd));
  image_t huge = mono;
  huge.width = 100000;
  corpus.Add("near_width_too_large", ImageInput(huge));
  corpus.Report();
}

// ---- template_cache -------------------------------------------------------------------

// A tiny hand-made bank (no rendering, so the bytes never depend on the GL driver): a
// 4 cm cube, `num_templates` templates with a 32 x 32 mask, an 8 x 8 thumbnail and four
// keypoints each. `with_symmetry` also fills what cache format 2 added: the cube's
// geometric symmetries (a quarter turn about z; the closure is not needed for parsing)
// and a few coloured appearance samples, one per corner.
TemplateBank MakeSeedBank(int num_templates, bool with_normals, bool with_symmetry) {
  TemplateBank bank;
  bank.object_id = "obj_000001";
  bank.mesh_hash = 0x5eed5eed5eed5eedULL;
  bank.mesh_path = "models/obj_000001.ply";
  bank.mesh_units = Units::kMillimetres;
  bank.options.crop.size_px = 32;
  bank.options.thumbnail_size_px = 8;
  bank.options.render_size_px = 64;
  bank.options.render_focal_px = 80.0;
  bank.template_camera = {80.0, 80.0, 32.0, 32.0, 64, 64};
  bank.online_mesh = test::MakeCube(0.02);
  if (with_normals) {
    for (const Eigen::Vector3f& vertex : bank.online_mesh.vertices)
      bank.online_mesh.normals.push_back(vertex.normalized());
  }
  bank.diameter_m = std::sqrt(3.0) * 0.04;
  bank.bounding_box =
      Eigen::AlignedBox3d(Eigen::Vector3d::Constant(-0.02), Eigen::Vector3d::Constant(0.02));
  if (with_symmetry) {
    Eigen::Isometry3d symmetry = Eigen::Isometry3d::Identity();
    symmetry.linear() = test::AxisAngle(M_PI / 2.0, Eigen::Vector3d::UnitZ());
    bank.symmetries.push_back(symmetry);
    bank.geometric_symmetries.discrete.push_back(symmetry);
    bank.geometric_symmetries.worst_error = 0.001;
    bank.geometric_symmetries.worst_p95_error = 0.002;
    bank.geometric_symmetries.diameter_m = bank.diameter_m;
    for (size_t i = 0; i < bank.online_mesh.vertices.size(); ++i) {
      const Eigen::Vector3f& vertex = bank.online_mesh.vertices[i];
      bank.appearance.points.push_back(vertex);
      bank.appearance.normals.push_back(vertex.normalized());
      bank.appearance.colors.emplace_back(0.125f * static_cast<float>(i), 0.5f, 1.0f);
      bank.ppf.points.push_back(vertex);  // the point-pair-feature model (format 3)
      bank.ppf.normals.push_back(vertex.normalized());
    }
    bank.ppf.options = bank.options.ppf;
    bank.ppf.step_m = 0.05 * bank.diameter_m;
  }
  for (int j = 0; j < num_templates; ++j) {
    Template t;
    t.cam_from_object.linear() = test::AxisAngle(0.3 + 0.5 * j, Eigen::Vector3d(1.0, 0.5, 0.2));
    t.cam_from_object.translation() = Eigen::Vector3d(0.0, 0.0, 0.25);
    t.crop_scale = 1.25;
    t.crop_offset = Eigen::Vector2d(12.0, 11.5);
    t.mask = cv::Mat::zeros(32, 32, CV_8UC1);
    cv::circle(t.mask, cv::Point(16, 16), 9 + j, cv::Scalar(255), cv::FILLED);
    t.thumbnail = cv::Mat(8, 8, CV_8UC1);
    for (int v = 0; v < 8; ++v)
      for (int u = 0; u < 8; ++u) t.thumbnail.at<uint8_t>(v, u) = static_cast<uint8_t>(20 * u + v);
    for (int i = 0; i < 4; ++i) {
      t.keypoints.emplace_back(20.0f + 6.0f * i, 24.0f + 2.0f * j);
      std::array<uint8_t, 32> descriptor;
      for (int b = 0; b < 32; ++b) descriptor[b] = static_cast<uint8_t>(37 * b + 11 * i + j);
      t.descriptors.push_back(descriptor);
      t.points.push_back(bank.online_mesh.vertices[(i + j) % 8]);
    }
    bank.templates.push_back(std::move(t));
  }
  return bank;
}

std::string CacheBytes(const TemplateBank& bank) {
  const fs::path path = fs::temp_directory_path() /
                        ("g6d_fuzz_make_seeds_" + std::to_string(::getpid()) + ".g6dcache");
  WriteTemplateCache(bank, path.string());
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  fs::remove(path);
  return bytes;
}

// The decompressed body of a cache file (after its 64-byte header, cache.h).
std::string BodyOf(const std::string& file) {
  const void* frame = file.data() + 64;
  const size_t frame_bytes = file.size() - 64;
  const unsigned long long size = ZSTD_getFrameContentSize(frame, frame_bytes);
  if (size == ZSTD_CONTENTSIZE_ERROR || size == ZSTD_CONTENTSIZE_UNKNOWN)
    G6D_THROW("cache body is not a zstd frame with a content size");
  std::string body(size, '\0');
  const size_t got = ZSTD_decompress(body.data(), body.size(), frame, frame_bytes);
  if (ZSTD_isError(got) || got != size) G6D_THROW("cannot decompress a cache body");
  return body;
}

void MakeCacheSeeds(const fs::path& fuzz_dir) {
  Corpus corpus(fuzz_dir, "template_cache");
  const std::string two = CacheBytes(MakeSeedBank(2, true, true));
  const std::string none = CacheBytes(MakeSeedBank(0, false, false));
  corpus.Add("valid_cache_2_templates", two);
  corpus.Add("valid_cache_no_templates", none);
  const std::string body_two = BodyOf(two);
  corpus.Add("valid_body_2_templates", body_two);
  corpus.Add("valid_body_no_templates", BodyOf(none));
  corpus.Add("valid_body_1_template", BodyOf(CacheBytes(MakeSeedBank(1, false, true))));

  std::string flipped = two;
  flipped[flipped.size() / 2] = static_cast<char>(flipped[flipped.size() / 2] ^ 0x10);
  corpus.Add("near_cache_body_checksum", flipped);
  corpus.Add("near_cache_truncated", two.substr(0, two.size() - 7));
  corpus.Add("near_cache_header_only", two.substr(0, 64));
  corpus.Add("near_body_truncated", body_two.substr(0, body_two.size() - 9));
  corpus.Add("near_body_trailing_byte", body_two + '\0');
  corpus.Report();
}

// ---- bop_json -------------------------------------------------------------------------

// The harness's input: the reader's selector byte ('0'..'3', value modulo 4) then text.
std::string JsonInput(char selector, const std::string& text) { return selector + text; }

// The three files of a scene input, separated by NUL bytes.
std::string SceneInput(const std::string& camera, const std::string& gt,
                       const std::string* gt_info) {
  std::string text = camera + '\0' + gt;
  if (gt_info != nullptr) text += '\0' + *gt_info;
  return JsonInput('3', text);
}

void MakeBopJsonSeeds(const fs::path& fuzz_dir) {
  Corpus corpus(fuzz_dir, "bop_json");
  // Targets (test_targets_bop19.json).
  corpus.Add("valid_targets", JsonInput('0', R"([
  {"im_id": 3, "inst_count": 1, "obj_id": 1, "scene_id": 2},
  {"im_id": 3, "inst_count": 2, "obj_id": 5, "scene_id": 2},
  {"im_id": 8, "inst_count": 1, "obj_id": 1, "scene_id": 2}
])"));
  corpus.Add("near_targets_missing_field",
             JsonInput('0', R"([{"im_id": 3, "obj_id": 1, "scene_id": 2}])"));
  corpus.Add("near_targets_float_id",
             JsonInput('0', R"([{"im_id": 3.5, "inst_count": 1, "obj_id": 1, "scene_id": 2}])"));
  corpus.Add(
      "near_targets_id_beyond_int",
      JsonInput('0', R"([{"im_id": 4294967299, "inst_count": 1, "obj_id": 1, "scene_id": 2}])"));
  corpus.Add("near_targets_malformed", JsonInput('0', R"([{"im_id": 3, "inst_count": 1,)"));

  // camera.json (the LM-O one).
  corpus.Add(
      "valid_camera",
      JsonInput(
          '1',
          R"({"cx": 325.2611, "cy": 242.04899, "depth_scale": 1.0, "fx": 572.4114, "fy": 573.57043, "height": 480, "width": 640})"));
  corpus.Add(
      "near_camera_zero_width",
      JsonInput(
          '1',
          R"({"cx": 325.3, "cy": 242.0, "fx": 572.4, "fy": 573.6, "height": 480, "width": 0})"));
  corpus.Add(
      "near_camera_missing_fy",
      JsonInput('1', R"({"cx": 325.3, "cy": 242.0, "fx": 572.4, "height": 480, "width": 640})"));

  // models_info.json: a plain object, a discrete and a continuous symmetry, the g6d
  // "mesh" and "units" extensions.
  corpus.Add("valid_models_info", JsonInput('2', R"({
  "1": {"diameter": 102.1, "min_x": -37.9, "min_y": -38.8, "min_z": -45.9, "size_x": 75.9, "size_y": 77.6, "size_z": 91.8},
  "10": {"diameter": 164.6, "min_x": -50.4, "min_y": -54.2, "min_z": -45.4, "size_x": 100.8, "size_y": 108.4, "size_z": 90.8,
         "symmetries_discrete": [[-0.99, -0.12, 0.03, 0.5, 0.12, -0.99, -0.01, 1.2, 0.03, -0.01, 1.0, 0.0, 0, 0, 0, 1]]},
  "13": {"diameter": 172.0, "symmetries_continuous": [{"axis": [0, 0, 1], "offset": [0, 0, 0]}]},
  "21": {"diameter": 120.5, "mesh": "obj_000021_textured.obj", "units": "m"}
})"));
  corpus.Add("near_models_info_bad_key", JsonInput('2', R"({"x3": {"diameter": 50}})"));
  corpus.Add("near_models_info_short_symmetry",
             JsonInput('2', R"({"3": {"diameter": 50, "symmetries_discrete": [[1, 0, 0]]}})"));
  corpus.Add(
      "near_models_info_zero_axis",
      JsonInput(
          '2',
          R"({"3": {"diameter": 50, "symmetries_continuous": [{"axis": [0, 0, 0], "offset": [0, 0, 0]}]}})"));
  corpus.Add("near_models_info_bad_units",
             JsonInput('2', R"({"3": {"diameter": 50, "units": "cm"}})"));

  // One scene: scene_camera.json, scene_gt.json, scene_gt_info.json.
  const std::string scene_camera = R"({
  "3": {"cam_K": [572.4114, 0.0, 325.2611, 0.0, 573.57043, 242.04899, 0.0, 0.0, 1.0], "depth_scale": 1.0},
  "8": {"cam_K": [572.4114, 0.0, 325.2611, 0.0, 573.57043, 242.04899, 0.0, 0.0, 1.0], "depth_scale": 0.1}
})";
  const std::string scene_gt = R"({
  "3": [{"cam_R_m2c": [0.0963, 0.9940, 0.0510, 0.5733, -0.0135, -0.8193, -0.8137, 0.1081, -0.5712], "cam_t_m2c": [-105.36, -117.52, 1014.87], "obj_id": 1},
        {"cam_R_m2c": [1, 0, 0, 0, 1, 0, 0, 0, 1], "cam_t_m2c": [10.0, 20.0, 800.0], "obj_id": 5}],
  "8": [{"cam_R_m2c": [1, 0, 0, 0, -1, 0, 0, 0, -1], "cam_t_m2c": [0, 0, 900], "obj_id": 1}]
})";
  const std::string scene_gt_info = R"({
  "3": [{"bbox_obj": [244, 150, 44, 58], "bbox_visib": [244, 150, 44, 58], "px_count_all": 1914, "px_count_valid": 1914, "px_count_visib": 1914, "visib_fract": 1.0},
        {"bbox_obj": [100, 100, 20, 30], "bbox_visib": [-1, -1, -1, -1], "px_count_all": 600, "px_count_valid": 0, "px_count_visib": 0, "visib_fract": 0.0}],
  "8": [{"bbox_obj": [300, 200, 40, 40], "bbox_visib": [300, 200, 20, 40], "px_count_all": 1600, "px_count_valid": 780, "px_count_visib": 800, "visib_fract": 0.5}]
})";
  corpus.Add("valid_scene", SceneInput(scene_camera, scene_gt, &scene_gt_info));
  corpus.Add("valid_scene_without_gt_info", SceneInput(scene_camera, scene_gt, nullptr));
  const std::string gt_unknown_image =
      R"({"9": [{"cam_R_m2c": [1, 0, 0, 0, 1, 0, 0, 0, 1], "cam_t_m2c": [0, 0, 1], "obj_id": 3}]})";
  corpus.Add("near_scene_gt_image_without_camera",
             SceneInput(scene_camera, gt_unknown_image, nullptr));
  const std::string short_info = R"({"3": [], "8": []})";
  corpus.Add("near_scene_gt_info_length", SceneInput(scene_camera, scene_gt, &short_info));
  const std::string bad_bbox = R"({"3": [{"bbox_obj": [1, 2, 3]}, {}], "8": [{}]})";
  corpus.Add("near_scene_gt_info_short_bbox", SceneInput(scene_camera, scene_gt, &bad_bbox));
  const std::string negative_scale =
      R"({"3": {"cam_K": [1, 0, 0, 0, 1, 0, 0, 0, 1], "depth_scale": -1}})";
  corpus.Add("near_scene_negative_depth_scale", SceneInput(negative_scale, "{}", nullptr));
  corpus.Report();
}

// ---- bop_csv --------------------------------------------------------------------------

void MakeBopCsvSeeds(const fs::path& fuzz_dir) {
  Corpus corpus(fuzz_dir, "bop_csv");
  std::vector<BopEstimate> estimates;
  for (const auto& [im_id, obj_id] : {std::pair<int, int>{3, 1}, {3, 5}, {8, 1}, {8, 12}}) {
    BopEstimate estimate;
    estimate.scene_id = 2;
    estimate.im_id = im_id;
    estimate.obj_id = obj_id;
    estimate.score = 1.0 / (1.0 + obj_id);
    estimate.cam_from_object.linear() =
        test::AxisAngle(0.1 * obj_id + 0.2 * im_id, Eigen::Vector3d(0.3, -1.0, 0.5));
    estimate.cam_from_object.translation() = Eigen::Vector3d(-0.1 * obj_id, 0.05, 0.9);
    estimate.time_s = im_id == 3 ? 0.4123 : -1.0;
    estimates.push_back(estimate);
  }
  std::ostringstream csv;
  WriteBopCsv(estimates, &csv);
  const std::string valid = csv.str();
  corpus.Add("valid_results", valid);
  corpus.Add("valid_crlf_blank_lines_no_header",
             "\r\n2,3,1,0.5,1 0 0 0 1 0 0 0 1,0 0 1000,0.25\r\n\r\n"
             "2,3,5,9.5e-1,1 0 0 0 -1 0 0 0 -1,  -1.5e2 2E1 8.0e+2 ,0.25\r\n");
  corpus.Add("near_six_fields",
             "scene_id,im_id,obj_id,score,R,t,time\n2,3,1,0.5,1 0 0 0 1 0 0 0 1,0.25\n");
  corpus.Add("near_nan_score", "2,3,1,nan,1 0 0 0 1 0 0 0 1,0 0 1000,0.25\n");
  corpus.Add("near_eight_rotation_numbers", "2,3,1,0.5,1 0 0 0 1 0 0 0,0 0 1000,0.25\n");
  corpus.Add("near_negative_id", "2,-3,1,0.5,1 0 0 0 1 0 0 0 1,0 0 1000,0.25\n");
  corpus.Add(
      "near_time_differs",
      "2,3,1,0.5,1 0 0 0 1 0 0 0 1,0 0 1000,0.25\n2,3,5,0.5,1 0 0 0 1 0 0 0 1,0 0 1000,0.5\n");
  corpus.Report();
}

// ---- foreign_message ------------------------------------------------------------------
// A type byte (0 Drake, 1 bot_core), then the message, 64 x 48 as the harness's camera.

template <typename Message>
std::string TypedSeed(uint8_t type, const Message& message) {
  std::string bytes(static_cast<size_t>(message.getEncodedSize()) + 1, '\0');
  bytes[0] = static_cast<char>(type);
  if (message.encode(bytes.data() + 1, 0, static_cast<int>(bytes.size()) - 1) < 0)
    G6D_THROW("encode failed");
  return bytes;
}

void MakeForeignSeeds(const fs::path& fuzz_dir) {
  Corpus corpus(fuzz_dir, "foreign_message");
  cv::Mat rgb(48, 64, CV_8UC3), depth_m(48, 64, CV_32F, cv::Scalar(0.6)), labels(48, 64, CV_16S,
                                                                               cv::Scalar(0));
  cv::randu(rgb, 0, 256);
  labels(cv::Rect(10, 10, 12, 9)) = 1;
  labels(cv::Rect(40, 20, 9, 9)) = 2;
  labels(cv::Rect(0, 40, 4, 4)) = 7;  // in no label map
  auto drake_image = [](const cv::Mat& image, int8_t format, int8_t channel, bool zlib) {
    return MakeDrakeImage(image, format, channel, zlib, 1, 1700000000000000, "cam");
  };
  using I = drake::lcmt_image;
  for (bool zlib : {true, false}) {
    drake::lcmt_image_array array;
    array.header.seq = 1;
    array.header.utime = 1700000000000000;
    array.header.frame_name = "";
    array.images = {drake_image(rgb, I::PIXEL_FORMAT_RGB, I::CHANNEL_TYPE_UINT8, zlib),
                    drake_image(depth_m, I::PIXEL_FORMAT_DEPTH, I::CHANNEL_TYPE_FLOAT32, zlib),
                    drake_image(labels, I::PIXEL_FORMAT_LABEL, I::CHANNEL_TYPE_INT16, zlib)};
    array.num_images = 3;
    const std::string seed = TypedSeed(0, array);
    corpus.Add(zlib ? "drake_zlib" : "drake_raw", seed);
    if (zlib) {
      corpus.Add("near_drake_truncated", seed.substr(0, seed.size() - 9));
      array.images[1].data[12] ^= 0x5A;
      corpus.Add("near_drake_corrupted_zlib", TypedSeed(0, array));
    }
  }
  auto bot_image = [](const cv::Mat& image, int32_t format, std::vector<uint8_t> data) {
    return MakeBotCoreImage(image, format, std::move(data), 1700000000000000);
  };
  cv::Mat depth_mm, mask;
  depth_m.convertTo(depth_mm, CV_16U, 1000.0);
  labels.convertTo(mask, CV_8U);
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", rgb, jpeg);
  for (bool mjpeg : {true, false}) {
    bot_core::images_t images;
    images.utime = 1700000000000000;
    images.images = {
        mjpeg ? bot_image(rgb, bot_core::image_t::PIXEL_FORMAT_MJPEG, jpeg)
              : bot_image(rgb, bot_core::image_t::PIXEL_FORMAT_RGB,
                          PixelBytes(rgb)),
        bot_image(depth_mm, bot_core::image_t::PIXEL_FORMAT_INVALID, ZlibCompress(PixelBytes(depth_mm))),
        bot_image(mask, bot_core::image_t::PIXEL_FORMAT_GRAY, ZlibCompress(PixelBytes(mask)))};
    images.image_types = {int16_t{bot_core::images_t::LEFT},
                          int16_t{bot_core::images_t::DEPTH_MM_ZIPPED},
                          int16_t{bot_core::images_t::MASK_ZIPPED}};
    images.n_images = 3;
    corpus.Add(mjpeg ? "bot_core_mjpeg" : "bot_core_raw", TypedSeed(1, images));
    if (!mjpeg) {
      images.images.pop_back();
      images.image_types.pop_back();
      images.n_images = 2;
      corpus.Add("near_bot_core_no_mask", TypedSeed(1, images));
    }
  }
  corpus.Report();
}

}  // namespace
}  // namespace g6d

int main(int argc, char** argv) {
  if (argc > 2) {
    std::fprintf(stderr, "usage: %s [FUZZ_DIR]  (default %s/tests/fuzz)\n", argv[0],
                 G6D_SOURCE_DIR);
    return 1;
  }
  const std::filesystem::path fuzz_dir =
      argc == 2 ? std::filesystem::path(argv[1])
                : std::filesystem::path(G6D_SOURCE_DIR) / "tests" / "fuzz";
  try {
    g6d::MakeFrameSeeds(fuzz_dir);
    g6d::MakeForeignSeeds(fuzz_dir);
    g6d::MakeImageSeeds(fuzz_dir);
    g6d::MakeCacheSeeds(fuzz_dir);
    g6d::MakeBopJsonSeeds(fuzz_dir);
    g6d::MakeBopCsvSeeds(fuzz_dir);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "g6d-fuzz-make-seeds: %s\n", e.what());
    return 1;
  }
  return 0;
}
