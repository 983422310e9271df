// Template matching (paper Sec. III-C): the nearest template descriptor of every query
// descriptor, Q_j of eq. (4), and the same result from the portable, AVX2 and AVX-512 loops.
#include "solver/match.h"

#include <random>

#include <gtest/gtest.h>

#include "core/executor.h"

namespace g6d {
namespace {

std::array<uint8_t, 32> RandomDescriptor(std::mt19937_64* rng) {
  std::array<uint8_t, 32> d;
  for (uint8_t& byte : d) byte = static_cast<uint8_t>((*rng)() & 0xff);
  return d;
}

// Flips `bits` distinct bits of `d`.
std::array<uint8_t, 32> Flip(std::array<uint8_t, 32> d, int bits, std::mt19937_64* rng) {
  std::vector<int> positions(256);
  for (int i = 0; i < 256; ++i) positions[static_cast<size_t>(i)] = i;
  std::shuffle(positions.begin(), positions.end(), *rng);
  for (int k = 0; k < bits; ++k) d[static_cast<size_t>(positions[static_cast<size_t>(k)] / 8)] ^= static_cast<uint8_t>(1 << (positions[static_cast<size_t>(k)] % 8));
  return d;
}

// A bank of random templates and a query of 37 features (not a multiple of 8) made of
// noisy copies of descriptors of the first five templates, exact duplicates (ties) and
// random ones.
struct Fixture {
  TemplateBank bank;
  std::vector<Feature> query;
  Fixture() {
    std::mt19937_64 rng(42);
    for (int j = 0; j < 20; ++j) {
      Template t;
      const int n = 30 + 7 * j;
      for (int k = 0; k < n; ++k) {
        t.descriptors.push_back(RandomDescriptor(&rng));
        t.points.emplace_back(0.001f * static_cast<float>(k), 0.002f * static_cast<float>(j), 0.0f);
      }
      if (j % 3 == 0) t.descriptors[5] = t.descriptors[2];  // a tie: the first must win
      bank.templates.push_back(t);
    }
    for (int i = 0; i < 37; ++i) {
      Feature f;
      f.xy = Eigen::Vector2f(static_cast<float>(i), static_cast<float>(2 * i));
      const Template& t = bank.templates[static_cast<size_t>(i % 5)];
      if (i % 4 == 3) f.descriptor = RandomDescriptor(&rng);
      else if (i % 4 == 2) f.descriptor = t.descriptors[2];
      else f.descriptor = Flip(t.descriptors[static_cast<size_t>(i) % t.descriptors.size()], 5 + i % 50, &rng);
      query.push_back(f);
    }
  }
};

TEST(MatchTemplates, NearestDescriptorQualityAndOrderAgreeWithBruteForce) {
  const Fixture f;
  MatchOptions options;
  options.min_correspondences = 4;
  InlineExecutor executor;
  std::vector<CorrespondenceSet> sets;
  MatchReport report;
  MatchTemplates(options, f.query, f.bank, &executor, &sets, &report);
  ASSERT_TRUE(report.success) << report.message;
  for (size_t s = 0; s < sets.size(); ++s) {
    const CorrespondenceSet& set = sets[s];
    const Template& t = f.bank.templates[static_cast<size_t>(set.template_index)];
    if (s > 0) EXPECT_GE(sets[s - 1].quality, set.quality);
    double quality = 0.0;
    size_t c = 0;
    for (size_t i = 0; i < f.query.size(); ++i) {
      int best = 257, index = -1;
      for (size_t k = 0; k < t.descriptors.size(); ++k) {
        const int d = HammingDistance(f.query[i].descriptor, t.descriptors[k]);
        if (d < best) best = d, index = static_cast<int>(k);
      }
      if (best >= options.hamming_threshold) continue;
      ASSERT_LT(c, set.query_indices.size());
      EXPECT_EQ(set.query_indices[c], static_cast<int>(i));
      EXPECT_EQ(set.distances[c], best);
      EXPECT_EQ(set.object_points[c], t.points[static_cast<size_t>(index)].cast<double>());
      quality += 1.0 - static_cast<double>(best) / options.hamming_threshold;
      ++c;
    }
    EXPECT_EQ(c, set.query_indices.size());
    EXPECT_DOUBLE_EQ(set.quality, quality);
  }
}

// The portable loop, the AVX2 loop and the AVX-512 one (each where the CPU has it; the
// portable one otherwise) find the same sets, ties included (the first of equals wins).
TEST(MatchTemplates, PortableAndSimdLoopsGiveTheSameSets) {
  const Fixture f;
  MatchOptions portable;
  portable.min_correspondences = 4;
  portable.simd = false;
  MatchOptions avx2 = portable;
  avx2.simd = true;
  avx2.simd_avx512 = false;
  MatchOptions best = avx2;
  best.simd_avx512 = true;
  ThreadPool pool(2);
  std::vector<CorrespondenceSet> a;
  MatchReport report_a;
  MatchTemplates(portable, f.query, f.bank, &pool, &a, &report_a);
  ASSERT_TRUE(report_a.success);
  for (const MatchOptions& options : {avx2, best}) {
    std::vector<CorrespondenceSet> b;
    MatchReport report_b;
    MatchTemplates(options, f.query, f.bank, &pool, &b, &report_b);
    ASSERT_EQ(a.size(), b.size());
    for (size_t s = 0; s < a.size(); ++s) {
      EXPECT_EQ(a[s].template_index, b[s].template_index);
      EXPECT_EQ(a[s].quality, b[s].quality);
      EXPECT_EQ(a[s].distances, b[s].distances);
      EXPECT_EQ(a[s].query_indices, b[s].query_indices);
      EXPECT_EQ(a[s].object_points, b[s].object_points);
    }
  }
}

}  // namespace
}  // namespace g6d
