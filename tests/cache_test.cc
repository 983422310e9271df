#include "templates/cache.h"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <zstd.h>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/hash.h"
#include "core/se3.h"
#include "test_util.h"

namespace g6d {
namespace {

using ::testing::HasSubstr;

// A bank with every field set to something non-default, built without rendering.
TemplateBank MakeBank(int num_templates, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::uniform_int_distribution<int> byte(0, 255);
  TemplateBank bank;
  bank.object_id = "obj_000042";
  bank.mesh_hash = 0x0123456789abcdefULL;
  bank.mesh_path = "/data/models/obj_000042.ply";
  bank.mesh_units = Units::kMillimetres;
  bank.options.views.num_directions = 7;
  bank.options.views.num_inplane = 2;
  bank.options.views.fill_fraction = 0.75;
  bank.options.crop.padding = 0.2;
  bank.options.crop.size_px = 128;
  bank.options.crop.background_gray = 3;
  bank.options.crop.normalized_std = 40.0;
  bank.options.orb.max_features = 123;
  bank.options.orb.scale_factor = 1.3f;
  bank.options.orb.fast_threshold = 9;
  bank.options.render_size_px = 200;
  bank.options.render_focal_px = 250.5;
  bank.options.online_mesh_faces = 77;
  bank.options.max_view_angle_deg = 70.0;
  bank.options.thumbnail_size_px = 32;
  bank.template_camera = {250.5, 250.5, 100.0, 100.0, 200, 200};
  bank.diameter_m = 0.123;
  bank.bounding_box =
      Eigen::AlignedBox3d(Eigen::Vector3d(-0.05, -0.04, -0.03), Eigen::Vector3d(0.05, 0.04, 0.03));
  bank.symmetries.push_back(
      MakePose(ExpSO3(Eigen::Vector3d(0.0, 0.0, M_PI)), Eigen::Vector3d(0.001, 0.0, 0.0)));
  bank.options.find_symmetries = false;
  bank.options.symmetry.sample_points = 321;
  bank.options.symmetry.mean_tolerance = 0.02;
  bank.options.symmetry.max_order = 5;
  bank.options.symmetry.seed = 9;
  bank.options.appearance.sample_points = 77;
  bank.options.appearance.seed = 11;
  bank.options.appearance.min_color_std = 0.05;
  bank.options.appearance.texture_max_side_px = 512;
  bank.geometric_symmetries.revolution = true;
  bank.geometric_symmetries.axis = Eigen::Vector3d(0.6, 0.0, 0.8);
  bank.geometric_symmetries.point = Eigen::Vector3d(0.001, -0.002, 0.003);
  bank.geometric_symmetries.worst_error = 0.004;
  bank.geometric_symmetries.worst_p95_error = 0.009;
  bank.geometric_symmetries.diameter_m = 0.123;
  bank.geometric_symmetries.discrete.push_back(
      MakePose(ExpSO3(Eigen::Vector3d(M_PI, 0.0, 0.0)), Eigen::Vector3d(0.0, 0.002, 0.0)));
  bank.options.ppf.step_fraction = 0.07;
  bank.options.ppf.max_points = 500;
  bank.ppf.options = bank.options.ppf;
  bank.ppf.step_m = 0.0086;
  for (int i = 0; i < 30; ++i) {
    bank.ppf.points.emplace_back(0.05f * uniform(rng), 0.05f * uniform(rng), 0.05f * uniform(rng));
    bank.ppf.normals.push_back(Eigen::Vector3f(uniform(rng), uniform(rng), 1.0f).normalized());
  }
  for (int i = 0; i < 20; ++i) {
    bank.appearance.points.emplace_back(uniform(rng), uniform(rng), uniform(rng));
    bank.appearance.normals.push_back(Eigen::Vector3f(uniform(rng), uniform(rng), 1.0f).normalized());
    bank.appearance.colors.emplace_back(byte(rng) / 255.0f, byte(rng) / 255.0f, byte(rng) / 255.0f);
  }
  for (int i = 0; i < 10; ++i) {
    bank.online_mesh.vertices.emplace_back(uniform(rng), uniform(rng), uniform(rng));
    bank.online_mesh.normals.emplace_back(
        Eigen::Vector3f(uniform(rng), uniform(rng), 1.0f).normalized());
  }
  for (int i = 0; i < 8; ++i) bank.online_mesh.faces.emplace_back(i, i + 1, i + 2);

  for (int j = 0; j < num_templates; ++j) {
    Template t;
    t.cam_from_object = MakePose(ExpSO3(Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng))),
                                 Eigen::Vector3d(uniform(rng), uniform(rng), 0.5 + uniform(rng)));
    t.crop_scale = 1.0 + 0.5 * uniform(rng);
    t.crop_offset = Eigen::Vector2d(10.0 * uniform(rng), 10.0 * uniform(rng));
    t.mask = cv::Mat::zeros(128, 128, CV_8UC1);
    cv::ellipse(t.mask, cv::Point(64, 64), cv::Size(40 + j, 30), 10.0 * j, 0, 360, cv::Scalar(255),
                cv::FILLED);
    t.thumbnail = cv::Mat(32, 32, CV_8UC1);
    for (int v = 0; v < 32; ++v)
      for (int u = 0; u < 32; ++u) t.thumbnail.at<uint8_t>(v, u) = static_cast<uint8_t>(byte(rng));
    const int n = 5 + 3 * j;
    for (int i = 0; i < n; ++i) {
      t.keypoints.emplace_back(200.0 * std::abs(uniform(rng)), 200.0 * std::abs(uniform(rng)));
      std::array<uint8_t, 32> d;
      for (auto& b : d) b = static_cast<uint8_t>(byte(rng));
      t.descriptors.push_back(d);
      t.points.emplace_back(0.05 * uniform(rng), 0.05 * uniform(rng), 0.05 * uniform(rng));
    }
    bank.templates.push_back(std::move(t));
  }
  return bank;
}

bool SameMat(const cv::Mat& a, const cv::Mat& b) {
  if (a.empty() || b.empty()) return a.empty() && b.empty();
  return a.type() == b.type() && a.size() == b.size() && cv::countNonZero(a != b) == 0;
}

void ExpectSameBank(const TemplateBank& a, const TemplateBank& b) {
  EXPECT_EQ(a.object_id, b.object_id);
  EXPECT_EQ(a.mesh_hash, b.mesh_hash);
  EXPECT_EQ(a.mesh_path, b.mesh_path);
  EXPECT_EQ(a.mesh_units, b.mesh_units);
  const TemplateBuildOptions& o = a.options;
  const TemplateBuildOptions& p = b.options;
  EXPECT_EQ(o.views.num_directions, p.views.num_directions);
  EXPECT_EQ(o.views.num_inplane, p.views.num_inplane);
  EXPECT_EQ(o.views.fill_fraction, p.views.fill_fraction);
  EXPECT_EQ(o.crop.padding, p.crop.padding);
  EXPECT_EQ(o.crop.size_px, p.crop.size_px);
  EXPECT_EQ(o.crop.background_gray, p.crop.background_gray);
  EXPECT_EQ(o.crop.normalized_mean, p.crop.normalized_mean);
  EXPECT_EQ(o.crop.normalized_std, p.crop.normalized_std);
  EXPECT_EQ(o.crop.min_std, p.crop.min_std);
  EXPECT_EQ(o.orb.max_features, p.orb.max_features);
  EXPECT_EQ(o.orb.scale_factor, p.orb.scale_factor);
  EXPECT_EQ(o.orb.num_levels, p.orb.num_levels);
  EXPECT_EQ(o.orb.edge_threshold, p.orb.edge_threshold);
  EXPECT_EQ(o.orb.fast_threshold, p.orb.fast_threshold);
  EXPECT_EQ(o.orb.mask_erosion_px, p.orb.mask_erosion_px);
  EXPECT_EQ(o.render_size_px, p.render_size_px);
  EXPECT_EQ(o.render_focal_px, p.render_focal_px);
  EXPECT_EQ(o.online_mesh_faces, p.online_mesh_faces);
  EXPECT_EQ(o.max_view_angle_deg, p.max_view_angle_deg);
  EXPECT_EQ(o.thumbnail_size_px, p.thumbnail_size_px);
  EXPECT_EQ(o.find_symmetries, p.find_symmetries);
  EXPECT_EQ(o.symmetry.sample_points, p.symmetry.sample_points);
  EXPECT_EQ(o.symmetry.mean_tolerance, p.symmetry.mean_tolerance);
  EXPECT_EQ(o.symmetry.max_tolerance, p.symmetry.max_tolerance);
  EXPECT_EQ(o.symmetry.max_order, p.symmetry.max_order);
  EXPECT_EQ(o.symmetry.seed, p.symmetry.seed);
  EXPECT_EQ(o.sample_appearance, p.sample_appearance);
  EXPECT_EQ(o.appearance.sample_points, p.appearance.sample_points);
  EXPECT_EQ(o.appearance.seed, p.appearance.seed);
  EXPECT_EQ(o.appearance.min_color_std, p.appearance.min_color_std);
  EXPECT_EQ(o.appearance.texture_max_side_px, p.appearance.texture_max_side_px);
  EXPECT_EQ(o.build_ppf, p.build_ppf);
  EXPECT_EQ(o.ppf.step_fraction, p.ppf.step_fraction);
  EXPECT_EQ(o.ppf.angle_step_deg, p.ppf.angle_step_deg);
  EXPECT_EQ(o.ppf.normal_cluster_deg, p.ppf.normal_cluster_deg);
  EXPECT_EQ(o.ppf.surface_samples, p.ppf.surface_samples);
  EXPECT_EQ(o.ppf.max_points, p.ppf.max_points);
  EXPECT_EQ(o.ppf.seed, p.ppf.seed);
  EXPECT_EQ(a.ppf.step_m, b.ppf.step_m);
  EXPECT_EQ(a.ppf.points, b.ppf.points);
  EXPECT_EQ(a.ppf.normals, b.ppf.normals);
  const MeshSymmetries& g = a.geometric_symmetries;
  const MeshSymmetries& h = b.geometric_symmetries;
  EXPECT_EQ(g.revolution, h.revolution);
  EXPECT_TRUE(g.axis == h.axis && g.point == h.point);
  EXPECT_EQ(g.worst_error, h.worst_error);
  EXPECT_EQ(g.worst_p95_error, h.worst_p95_error);
  EXPECT_EQ(g.diameter_m, h.diameter_m);
  ASSERT_EQ(g.discrete.size(), h.discrete.size());
  for (size_t i = 0; i < g.discrete.size(); ++i) EXPECT_TRUE(g.discrete[i].matrix() == h.discrete[i].matrix());
  ASSERT_EQ(a.appearance.points.size(), b.appearance.points.size());
  for (size_t i = 0; i < a.appearance.points.size(); ++i) {
    EXPECT_EQ(a.appearance.points[i], b.appearance.points[i]);
    EXPECT_EQ(a.appearance.normals[i], b.appearance.normals[i]);
    EXPECT_EQ(a.appearance.colors[i], b.appearance.colors[i]);  // on the 8-bit grid both sides
  }
  const Camera& c = a.template_camera;
  const Camera& d = b.template_camera;
  EXPECT_EQ(c.fx, d.fx);
  EXPECT_EQ(c.fy, d.fy);
  EXPECT_EQ(c.cx, d.cx);
  EXPECT_EQ(c.cy, d.cy);
  EXPECT_EQ(c.width, d.width);
  EXPECT_EQ(c.height, d.height);
  EXPECT_EQ(a.diameter_m, b.diameter_m);
  EXPECT_EQ(a.bounding_box.min(), b.bounding_box.min());
  EXPECT_EQ(a.bounding_box.max(), b.bounding_box.max());
  ASSERT_EQ(a.symmetries.size(), b.symmetries.size());
  for (size_t i = 0; i < a.symmetries.size(); ++i) {
    EXPECT_EQ(a.symmetries[i].matrix(), b.symmetries[i].matrix());
  }
  EXPECT_EQ(a.online_mesh.vertices, b.online_mesh.vertices);
  EXPECT_EQ(a.online_mesh.faces, b.online_mesh.faces);
  EXPECT_EQ(a.online_mesh.normals, b.online_mesh.normals);
  ASSERT_EQ(a.templates.size(), b.templates.size());
  for (size_t j = 0; j < a.templates.size(); ++j) {
    const Template& s = a.templates[j];
    const Template& t = b.templates[j];
    EXPECT_EQ(s.cam_from_object.matrix(), t.cam_from_object.matrix()) << "template " << j;
    EXPECT_EQ(s.crop_scale, t.crop_scale);
    EXPECT_EQ(s.crop_offset, t.crop_offset);
    EXPECT_TRUE(SameMat(s.mask, t.mask)) << "template " << j;
    EXPECT_TRUE(SameMat(s.thumbnail, t.thumbnail)) << "template " << j;
    EXPECT_EQ(s.keypoints, t.keypoints);
    EXPECT_EQ(s.descriptors, t.descriptors);
    EXPECT_EQ(s.points, t.points);
  }
}

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

std::string EncodedBank(const TemplateBank& bank, const std::string& name) {
  const std::string path = test::TempDir(name) + "/bank.g6dcache";
  WriteTemplateCache(bank, path);
  return ReadBytes(path);
}

// Expects ParseTemplateCache to throw g6d::Error whose message contains `needle`.
void ExpectRefused(const std::string& bytes, const std::string& needle) {
  try {
    ParseTemplateCache(bytes, "test cache");
    ADD_FAILURE() << "accepted; expected an error containing '" << needle << "'";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr(needle));
    EXPECT_THAT(e.what(), HasSubstr("test cache"));
  }
}

// Layout facts the crafted-file tests rely on (cache.h): a 64-byte header with the
// uncompressed size at 16, the compressed size at 24, the body checksum at 32 and the
// header checksum (FNV-1a 64 of bytes 0..55) at 56.
void StoreU64(uint64_t value, std::string* bytes, size_t offset) {
  for (int i = 0; i < 8; ++i) (*bytes)[offset + i] = static_cast<char>(value >> (8 * i));
}
void ResealHeader(std::string* bytes) { StoreU64(Fnv1a64(bytes->data(), 56), bytes, 56); }

// Replaces the body of a valid file with `body`, recomputing sizes and checksums.
std::string WithBody(const std::string& file, const std::string& body) {
  std::string compressed(ZSTD_compressBound(body.size()), '\0');
  const size_t size =
      ZSTD_compress(compressed.data(), compressed.size(), body.data(), body.size(), 3);
  EXPECT_FALSE(ZSTD_isError(size));
  compressed.resize(size);
  std::string out = file.substr(0, 64) + compressed;
  StoreU64(body.size(), &out, 16);
  StoreU64(compressed.size(), &out, 24);
  StoreU64(Fnv1a64(compressed.data(), compressed.size()), &out, 32);
  ResealHeader(&out);
  return out;
}

std::string BodyOf(const std::string& file) {
  const unsigned long long size = ZSTD_getFrameContentSize(file.data() + 64, file.size() - 64);
  std::string body(size, '\0');
  EXPECT_EQ(ZSTD_decompress(body.data(), body.size(), file.data() + 64, file.size() - 64), size);
  return body;
}

TEST(TemplateCache, RoundTripIsExact) {
  const TemplateBank bank = MakeBank(6, 1);
  const std::string dir = test::TempDir("cache_round_trip");
  const std::string path = dir + "/obj.g6dcache";
  WriteTemplateCache(bank, path);
  const TemplateBank read = ReadTemplateCache(path);
  ExpectSameBank(bank, read);
  // The point-pair-feature table is derived on reading: every ordered pair of its 30 points.
  EXPECT_EQ(read.ppf.entries.size(), 30u * 29u);
  // No temporary file is left beside the cache.
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    (void)entry;
    ++files;
  }
  EXPECT_EQ(files, 1);
  // Writing is deterministic.
  WriteTemplateCache(bank, dir + "/again.g6dcache");
  EXPECT_EQ(ReadBytes(path), ReadBytes(dir + "/again.g6dcache"));
}

TEST(TemplateCache, RoundTripOfEmptyPieces) {
  TemplateBank bank = MakeBank(2, 2);
  bank.symmetries.clear();
  bank.online_mesh.normals.clear();
  bank.templates[0].keypoints.clear();
  bank.templates[0].descriptors.clear();
  bank.templates[0].points.clear();
  bank.templates[1].thumbnail = cv::Mat();
  bank.templates[1].mask = cv::Mat::zeros(128, 128, CV_8UC1);
  bank.templates[1].mask.at<uint8_t>(127, 127) = 255;  // run ending on the last pixel
  ExpectSameBank(bank, ParseTemplateCache(EncodedBank(bank, "cache_empty"), "x"));
}

TEST(TemplateCache, EverySingleByteFlipIsRefused) {
  const std::string file = EncodedBank(MakeBank(2, 3), "cache_flip");
  for (size_t i = 0; i < file.size(); ++i) {
    std::string damaged = file;
    damaged[i] = static_cast<char>(damaged[i] ^ 0x10);
    EXPECT_THROW(ParseTemplateCache(damaged, "flipped"), Error) << "byte " << i;
  }
}

TEST(TemplateCache, CorruptedBodyIsRefused) {
  std::string file = EncodedBank(MakeBank(3, 4), "cache_corrupt");
  file[file.size() / 2] = static_cast<char>(file[file.size() / 2] ^ 0x01);
  ExpectRefused(file, "corrupted: checksum mismatch");
  // Also through the file API.
  const std::string path = test::TempDir("cache_corrupt_file") + "/bad.g6dcache";
  WriteBytes(path, file);
  try {
    ReadTemplateCache(path);
    ADD_FAILURE() << "accepted a corrupted file";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("corrupted: checksum mismatch"));
    EXPECT_THAT(e.what(), HasSubstr(path));
  }
}

TEST(TemplateCache, TruncatedFileIsRefused) {
  const std::string file = EncodedBank(MakeBank(3, 5), "cache_truncated");
  for (size_t keep : {file.size() - 1, file.size() / 2, size_t{64}, size_t{40}, size_t{3}}) {
    ExpectRefused(file.substr(0, keep), "truncated");
  }
  const std::string path = test::TempDir("cache_truncated_file") + "/short.g6dcache";
  WriteBytes(path, file.substr(0, file.size() - 10));
  EXPECT_THROW(ReadTemplateCache(path), Error);
}

TEST(TemplateCache, WrongVersionIsRefused) {
  std::string file = EncodedBank(MakeBank(1, 6), "cache_version");
  file[8] = 1;  // a version-1 cache (before symmetries and appearance samples)
  ResealHeader(&file);
  ExpectRefused(file, "unsupported cache format version 1 (expected 3; version 3 stores the point-pair-feature "
                      "model that finds texture-less objects); rebuild it with g6d-build-templates");
  file[8] = 2;  // even an unsealed header with the right version is still checked
  file[9] = 1;
  ExpectRefused(file, "unsupported cache format version 258");
}

// The committed fuzz seeds (tests/fuzz/corpus/template_cache/, written by
// g6d-fuzz-make-seeds) must be of the current format, or fuzzing starts at the version
// check; after a format change, regenerate them.
TEST(TemplateCache, CommittedFuzzSeedsAreOfTheCurrentFormat) {
  const std::string dir = test::SourceDir() + "/tests/fuzz/corpus/template_cache/";
  for (const char* name : {"valid_cache_2_templates", "valid_cache_no_templates"}) {
    SCOPED_TRACE(name);
    const std::string file = ReadBytes(dir + name);
    ASSERT_GE(file.size(), 64u);
    uint32_t version = 0;
    std::memcpy(&version, file.data() + 8, 4);
    EXPECT_EQ(version, kCacheFormatVersion);
    EXPECT_NO_THROW(ParseTemplateCache(file, name));
  }
  // One seed carries what format 2 added, so the fuzzer starts next to those fields.
  const TemplateBank two = ParseTemplateCache(ReadBytes(dir + "valid_cache_2_templates"), "two");
  EXPECT_FALSE(two.geometric_symmetries.discrete.empty());
  EXPECT_FALSE(two.appearance.Empty());
  EXPECT_FALSE(two.ppf.points.empty());
  for (const char* name :
       {"valid_body_no_templates", "valid_body_1_template", "valid_body_2_templates"}) {
    SCOPED_TRACE(name);
    EXPECT_NO_THROW(ParseTemplateCacheBody(ReadBytes(dir + name), name));
  }
}

TEST(TemplateCache, BadMagicIsRefused) {
  std::string file = EncodedBank(MakeBank(1, 7), "cache_magic");
  file[0] = 'X';
  ExpectRefused(file, "not a g6d cache (bad magic)");
  ExpectRefused("PLY format ascii 1.0 and much more text than a header needs ...........",
                "not a g6d cache (bad magic)");
}

TEST(TemplateCache, MissingFileNamesThePath) {
  try {
    ReadTemplateCache("/nonexistent/dir/obj.g6dcache");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("/nonexistent/dir/obj.g6dcache"));
  }
}

TEST(TemplateCache, StaleMeshIsRefusedByTheCheckedReader) {
  const std::string dir = test::TempDir("cache_stale");
  const std::string mesh_path = dir + "/mesh.ply";
  WriteBytes(mesh_path, "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n");
  TemplateBank bank = MakeBank(1, 8);
  bank.mesh_hash = HashFile(mesh_path);
  const std::string path = dir + "/obj.g6dcache";
  WriteTemplateCache(bank, path);
  EXPECT_NO_THROW(ReadTemplateCacheChecked(path, mesh_path));
  WriteBytes(mesh_path, "ply\nformat ascii 1.0\nelement vertex 1\nend_header\n0 0 0\n");
  try {
    ReadTemplateCacheChecked(path, mesh_path);
    ADD_FAILURE() << "accepted a stale cache";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("stale: mesh hash"));
    EXPECT_THAT(e.what(), HasSubstr(HexString(bank.mesh_hash)));
  }
}

TEST(TemplateCache, HugeDeclaredSizesAreRefusedWithoutAllocating) {
  // A bank whose body ends with the template count (no templates).
  const std::string file = EncodedBank(MakeBank(0, 9), "cache_huge");
  std::string body = BodyOf(file);
  ASSERT_GE(body.size(), 4u);
  // Sanity: re-sealing the unchanged body gives a valid file.
  EXPECT_NO_THROW(ParseTemplateCache(WithBody(file, body), "resealed"));

  // 4e9 templates: over the limit.
  std::string huge = body;
  for (int i = 1; i <= 4; ++i) huge[huge.size() - i] = static_cast<char>(0xee);
  ExpectRefused(WithBody(file, huge), "template count");

  // 90000 templates: under the limit but not backed by the remaining bytes.
  std::string many = body;
  const uint32_t count = 90000;
  std::memcpy(&many[many.size() - 4], &count, 4);  // little-endian host assumed by the test
  ExpectRefused(WithBody(file, many), "truncated: template count 90000");

  // One template whose keypoint count is large and unbacked.
  const TemplateBank one = MakeBank(1, 9);
  std::string body_one = BodyOf(EncodedBank(one, "cache_huge_one"));
  // The keypoint count sits right before the 5 keypoints' data (5 * 52 bytes).
  const size_t count_offset = body_one.size() - 5 * 52 - 4;
  uint32_t stored = 0;
  std::memcpy(&stored, &body_one[count_offset], 4);
  ASSERT_EQ(stored, 5u);
  const uint32_t keypoints = 99999;
  std::memcpy(&body_one[count_offset], &keypoints, 4);
  ExpectRefused(WithBody(file, body_one), "keypoint count 99999");

  // Header declaring an absurd uncompressed size.
  std::string absurd = file;
  StoreU64(uint64_t{1} << 60, &absurd, 16);
  ResealHeader(&absurd);
  ExpectRefused(absurd, "body size");

  // A header declaring just over the 256 MiB body limit: refused before the reader
  // allocates the declared size (a 64 KB zstd bomb could otherwise cost 2 GiB).
  std::string bomb = file;
  StoreU64((uint64_t{256} << 20) + 1, &bomb, 16);
  ResealHeader(&bomb);
  ExpectRefused(bomb, "exceeds the limit of 268435456 bytes");

  // Trailing garbage after the body.
  ExpectRefused(file + "junk", "corrupted");
}

// Bodies with valid checksums but damaged content (a buggy or hostile writer): every one
// must either parse into a bank or be refused with g6d::Error; never crash or over-allocate.
TEST(TemplateCache, ResealedGarbageBodiesNeverCrash) {
  const std::string file = EncodedBank(MakeBank(3, 11), "cache_fuzz");
  const std::string body = BodyOf(file);
  std::mt19937 rng(12);
  std::uniform_int_distribution<size_t> position(0, body.size() - 1);
  std::uniform_int_distribution<int> byte(0, 255);
  int refused = 0;
  for (int iteration = 0; iteration < 400; ++iteration) {
    std::string damaged = body;
    if (iteration % 4 == 3) {
      damaged.resize(position(rng));  // cut anywhere: always refused
    } else {
      const int flips = 1 + iteration % 3;
      for (int k = 0; k < flips; ++k) damaged[position(rng)] = static_cast<char>(byte(rng));
    }
    try {
      ParseTemplateCache(WithBody(file, damaged), "fuzz");
    } catch (const Error&) {
      ++refused;
    }
  }
  // Most damage lands in data (descriptors, masks, images) a reader cannot tell from valid
  // values; truncations are always caught.
  EXPECT_GE(refused, 100);
}

TEST(ParseTemplateCacheBody, ParsesTheBodyOfAWrittenCache) {
  const TemplateBank bank = MakeBank(3, 13);
  const std::string body = BodyOf(EncodedBank(bank, "cache_body"));
  ExpectSameBank(bank, ParseTemplateCacheBody(body, "body"));
  try {
    ParseTemplateCacheBody(body.substr(0, body.size() - 1), "cut body");
    ADD_FAILURE() << "a truncated body was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("cut body: truncated"));
  }
}

// The body bytes of one template: identity pose, a mask of `mask_side` squared pixels in a
// single run of zeros, no thumbnail, no keypoints (148 bytes).
std::string OneRunTemplate(int32_t mask_side) {
  std::string bytes;
  auto append = [&](const void* data, size_t size) {
    bytes.append(static_cast<const char*>(data), size);  // little-endian host assumed
  };
  for (int i = 0; i < 12; ++i) {
    const double value = (i < 9 && i % 4 == 0) ? 1.0 : (i == 11 ? 0.5 : 0.0);
    append(&value, 8);
  }
  for (double value : {1.0, 0.0, 0.0}) append(&value, 8);  // crop scale and offset
  const uint32_t pixels = static_cast<uint32_t>(mask_side) * static_cast<uint32_t>(mask_side);
  for (uint32_t value : {static_cast<uint32_t>(mask_side), static_cast<uint32_t>(mask_side),
                         uint32_t{1}, pixels, uint32_t{0}, uint32_t{0}, uint32_t{0}}) {
    append(&value, 4);
  }
  return bytes;
}

// `body` (of a bank without templates, ending with the template count) declaring
// `count` copies of `one_template`.
std::string WithTemplates(std::string body, uint32_t count, const std::string& one_template) {
  body.resize(body.size() - 4);
  body.append(reinterpret_cast<const char*>(&count), 4);
  for (uint32_t i = 0; i < count; ++i) body += one_template;
  return body;
}

// Fuzz hardening (input tests/fuzz/regressions/template_cache/mask-amplification, crafted
// while checking huge declared sizes; it drove the fuzz target over its 2 GB limit): masks
// are run-length coded, so 148 bytes declared a 8192 x 8192 mask and a 4.6 KB body made
// the reader allocate 1.8 GB. Masks must now be crop.size_px squares. (The input is the
// seed corpus' valid_body_no_templates with 28 OneRunTemplate(8192) appended; it was
// rebuilt that way for cache format 2, whose longer body the version-1 input no longer
// parsed far enough to reach the masks.)
TEST(ParseTemplateCacheBody, FuzzRunLengthMaskOfAnySizeIsRefused) {
  const TemplateBank bank = MakeBank(0, 14);  // crop.size_px 128
  const std::string body = BodyOf(EncodedBank(bank, "cache_mask_size"));
  EXPECT_NO_THROW(ParseTemplateCacheBody(WithTemplates(body, 2, OneRunTemplate(128)), "ok"));
  try {
    ParseTemplateCacheBody(WithTemplates(body, 28, OneRunTemplate(8192)), "amplified");
    ADD_FAILURE() << "a 8192 x 8192 mask was accepted with crop.size_px 128";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("template mask has a bad size 8192x8192 (expected 128x128"));
  }
  // The committed input still gets as far as the masks (a format change must keep it so).
  const std::string input =
      ReadBytes(test::SourceDir() + "/tests/fuzz/regressions/template_cache/mask-amplification");
  try {
    ParseTemplateCacheBody(input, "regression");
    ADD_FAILURE() << "the regression input was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("template mask has a bad size 8192x8192"));
  }
}

// The same amplification within the size rule: 200 masks of 4096 x 4096 (crop.size_px may
// be 4096) are 3.4 GB; refused from the template count, before any mask is allocated.
TEST(ParseTemplateCacheBody, FuzzMasksOverTheTotalLimitAreRefusedBeforeAllocating) {
  TemplateBank bank = MakeBank(0, 15);
  bank.options.crop.size_px = 4096;
  const std::string body = BodyOf(EncodedBank(bank, "cache_mask_budget"));
  try {
    ParseTemplateCacheBody(WithTemplates(body, 200, OneRunTemplate(4096)), "budget");
    ADD_FAILURE() << "3.4 GB of masks were accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("bytes of masks and thumbnails, more than the limit"));
  }
}

TEST(TemplateCache, MaskOrThumbnailOfAnotherSizeIsNotWritten) {
  TemplateBank bank = MakeBank(2, 16);
  bank.templates[1].mask = cv::Mat::zeros(64, 64, CV_8UC1);  // crop.size_px is 128
  const std::string dir = test::TempDir("cache_wrong_mask");
  try {
    WriteTemplateCache(bank, dir + "/obj.g6dcache");
    ADD_FAILURE() << "a 64 x 64 mask was written with crop.size_px 128";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("mask has a bad size 64x64 (expected 128x128"));
  }
  bank = MakeBank(2, 16);
  bank.templates[0].thumbnail = cv::Mat::zeros(16, 16, CV_8UC1);  // thumbnail_size_px is 32
  EXPECT_THROW(WriteTemplateCache(bank, dir + "/obj.g6dcache"), Error);
}

TEST(TemplateCache, UnwritableTargetThrows) {
  EXPECT_THROW(WriteTemplateCache(MakeBank(1, 10), "/nonexistent/dir/obj.g6dcache"), Error);
  TemplateBank bad = MakeBank(1, 10);
  bad.symmetries[0].linear() *= 1.01;  // not a rotation: refused on write, never half-written
  EXPECT_THROW(WriteTemplateCache(bad, test::TempDir("cache_bad") + "/bad.g6dcache"), Error);
}

}  // namespace
}  // namespace g6d
