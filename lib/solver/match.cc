#include "solver/match.h"

#include <algorithm>
#include <cstring>
#include <numeric>
#include <sstream>

#include "core/camera.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

namespace g6d {

std::string MatchOptions::Check() const {
  std::ostringstream out;
  if (hamming_threshold < 1 || hamming_threshold > 256) out << "MatchOptions.hamming_threshold must be in 1..256 (got " << hamming_threshold << ")";
  else if (max_sets < 1) out << "MatchOptions.max_sets must be >= 1 (got " << max_sets << ")";
  else if (min_correspondences < 4) out << "MatchOptions.min_correspondences must be >= 4 (got " << min_correspondences << ")";
  return out.str();
}

namespace {
struct Words {
  uint64_t w[4];
};
inline Words Load(const std::array<uint8_t, 32>& d) {
  Words words;
  std::memcpy(words.w, d.data(), 32);
  return words;
}
inline int Distance(const Words& a, const Words& b) {
  return __builtin_popcountll(a.w[0] ^ b.w[0]) + __builtin_popcountll(a.w[1] ^ b.w[1]) +
         __builtin_popcountll(a.w[2] ^ b.w[2]) + __builtin_popcountll(a.w[3] ^ b.w[3]);
}
// Nearest template descriptor of every query descriptor (first of equals wins). This is
// the hot loop of matching (500 x 324 x ~200 distances per instance). The build targets
// baseline x86-64, which has no popcount instruction, so the loop is compiled again for
// CPUs with POPCNT / AVX2 and the best clone is picked at load time; the results are the
// same bit for bit.
// Sanitizer builds skip the clones: the ifunc resolver runs before the TSan/ASan runtime
// is initialized and crashes every binary at load time.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__SANITIZE_THREAD__) && !defined(__SANITIZE_ADDRESS__)
__attribute__((target_clones("avx2", "popcnt", "default")))
#endif
void NearestDescriptors(const std::vector<Words>& query, const std::vector<Words>& candidates, int* best_distance,
                        int* best_index) {
  for (size_t i = 0; i < query.size(); ++i) {
    int best = 257, index = -1;
    for (size_t k = 0; k < candidates.size(); ++k) {
      const int d = Distance(query[i], candidates[k]);
      if (d < best) {
        best = d;
        index = static_cast<int>(k);
      }
    }
    best_distance[i] = best;
    best_index[i] = index;
  }
}


// The query descriptors as four planes of 64-bit words (word w of descriptor i at
// words[w][i]), zero-padded to a multiple of 8 descriptors.
struct QueryPlanes {
  std::vector<uint64_t> words[4];
  size_t count = 0;
};

QueryPlanes MakeQueryPlanes(const std::vector<Words>& query) {
  QueryPlanes planes;
  planes.count = query.size();
  const size_t padded = (query.size() + 7) / 8 * 8;
  for (int w = 0; w < 4; ++w) {
    planes.words[w].assign(padded, 0);
    for (size_t i = 0; i < query.size(); ++i) planes.words[w][i] = query[i].w[w];
  }
  return planes;
}

#if defined(__x86_64__) && defined(__GNUC__)
#define G6D_HAVE_AVX512_MATCH 1
// NearestDescriptors with AVX-512 VPOPCNTDQ: eight query descriptors per register, the
// template's descriptors in order; a lane takes a candidate only when strictly nearer, so
// ties keep the first, exactly as the scalar loop (same result bit for bit).
__attribute__((target("avx512f,avx512vpopcntdq"))) void NearestDescriptorsAvx512(
    const QueryPlanes& query, const std::vector<Words>& candidates, int* best_distance, int* best_index) {
  for (size_t i = 0; i < query.count; i += 8) {
    const __m512i q0 = _mm512_loadu_si512(query.words[0].data() + i);
    const __m512i q1 = _mm512_loadu_si512(query.words[1].data() + i);
    const __m512i q2 = _mm512_loadu_si512(query.words[2].data() + i);
    const __m512i q3 = _mm512_loadu_si512(query.words[3].data() + i);
    __m512i best = _mm512_set1_epi64(257);
    __m512i index = _mm512_set1_epi64(-1);
    for (size_t k = 0; k < candidates.size(); ++k) {
      const Words& c = candidates[k];
      __m512i d = _mm512_popcnt_epi64(_mm512_xor_si512(q0, _mm512_set1_epi64(static_cast<long long>(c.w[0]))));
      d = _mm512_add_epi64(d, _mm512_popcnt_epi64(_mm512_xor_si512(q1, _mm512_set1_epi64(static_cast<long long>(c.w[1])))));
      d = _mm512_add_epi64(d, _mm512_popcnt_epi64(_mm512_xor_si512(q2, _mm512_set1_epi64(static_cast<long long>(c.w[2])))));
      d = _mm512_add_epi64(d, _mm512_popcnt_epi64(_mm512_xor_si512(q3, _mm512_set1_epi64(static_cast<long long>(c.w[3])))));
      const __mmask8 nearer = _mm512_cmplt_epi64_mask(d, best);
      best = _mm512_mask_mov_epi64(best, nearer, d);
      index = _mm512_mask_mov_epi64(index, nearer, _mm512_set1_epi64(static_cast<long long>(k)));
    }
    alignas(64) int64_t lane_best[8], lane_index[8];
    _mm512_store_si512(lane_best, best);
    _mm512_store_si512(lane_index, index);
    for (size_t lane = 0; lane < 8 && i + lane < query.count; ++lane) {
      best_distance[i + lane] = static_cast<int>(lane_best[lane]);
      best_index[i + lane] = static_cast<int>(lane_index[lane]);
    }
  }
}

bool CpuHasAvx512Popcount() {
  static const bool has = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vpopcntdq");
  return has;
}

// The bytes' bit counts of `x` (each 0..8): a 16-entry table looked up by each half-byte.
__attribute__((target("avx2"))) inline __m256i ByteBitCounts(__m256i x) {
  const __m256i table = _mm256_setr_epi8(0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4,  //
                                         0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4);
  const __m256i low_nibbles = _mm256_set1_epi8(0x0F);
  const __m256i low = _mm256_and_si256(x, low_nibbles);
  const __m256i high = _mm256_and_si256(_mm256_srli_epi16(x, 4), low_nibbles);
  return _mm256_add_epi8(_mm256_shuffle_epi8(table, low), _mm256_shuffle_epi8(table, high));
}

// NearestDescriptors for CPUs with AVX2 but no AVX-512 VPOPCNTDQ (most x86-64 machines of
// the last ten years): eight query descriptors at a time in two registers of four 64-bit
// lanes; a lane's bit count is the sum of its bytes' counts (a half-byte table, then the sum
// of absolute differences against zero: 4 words x 8 bytes x at most 8 bits fits a byte).
// A lane takes a candidate only when strictly nearer, so ties keep the first: the same result
// bit for bit as the scalar loop. About twice as fast as the scalar loop with POPCNT.
__attribute__((target("avx2"))) void NearestDescriptorsAvx2(const QueryPlanes& query, const std::vector<Words>& candidates,
                                                            int* best_distance, int* best_index) {
  const __m256i zero = _mm256_setzero_si256();
  for (size_t i = 0; i < query.count; i += 8) {
    __m256i a[4], b[4];
    for (int w = 0; w < 4; ++w) {
      a[w] = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(query.words[w].data() + i));
      b[w] = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(query.words[w].data() + i + 4));
    }
    __m256i best_a = _mm256_set1_epi64x(257), best_b = best_a;
    __m256i index_a = _mm256_set1_epi64x(-1), index_b = index_a;
    for (size_t k = 0; k < candidates.size(); ++k) {
      __m256i counts_a = zero, counts_b = zero;
      for (int w = 0; w < 4; ++w) {
        const __m256i c = _mm256_set1_epi64x(static_cast<long long>(candidates[k].w[w]));
        counts_a = _mm256_add_epi8(counts_a, ByteBitCounts(_mm256_xor_si256(a[w], c)));
        counts_b = _mm256_add_epi8(counts_b, ByteBitCounts(_mm256_xor_si256(b[w], c)));
      }
      const __m256i d_a = _mm256_sad_epu8(counts_a, zero), d_b = _mm256_sad_epu8(counts_b, zero);
      const __m256i k_lanes = _mm256_set1_epi64x(static_cast<long long>(k));
      const __m256i nearer_a = _mm256_cmpgt_epi64(best_a, d_a), nearer_b = _mm256_cmpgt_epi64(best_b, d_b);
      best_a = _mm256_blendv_epi8(best_a, d_a, nearer_a);
      index_a = _mm256_blendv_epi8(index_a, k_lanes, nearer_a);
      best_b = _mm256_blendv_epi8(best_b, d_b, nearer_b);
      index_b = _mm256_blendv_epi8(index_b, k_lanes, nearer_b);
    }
    alignas(32) int64_t lane_best[8], lane_index[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(lane_best), best_a);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lane_best + 4), best_b);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lane_index), index_a);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lane_index + 4), index_b);
    for (size_t lane = 0; lane < 8 && i + lane < query.count; ++lane) {
      best_distance[i + lane] = static_cast<int>(lane_best[lane]);
      best_index[i + lane] = static_cast<int>(lane_index[lane]);
    }
  }
}

bool CpuHasAvx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}
#endif

}  // namespace

int HammingDistance(const std::array<uint8_t, 32>& a, const std::array<uint8_t, 32>& b) {
  return Distance(Load(a), Load(b));
}

void MatchTemplates(const MatchOptions& options, const std::vector<Feature>& query,
                    const TemplateBank& bank, Executor* executor,
                    std::vector<CorrespondenceSet>* sets, MatchReport* report) {
  *report = MatchReport();
  sets->clear();
  const std::string bad = options.Check();
  if (!bad.empty()) {
    report->message = bad;
    return;
  }
  report->query_features = static_cast<int>(query.size());
  if (query.size() < static_cast<size_t>(options.min_correspondences)) {
    report->message = "too few query features (" + std::to_string(query.size()) + ")";
    return;
  }
  std::vector<Words> query_words(query.size());
  for (size_t i = 0; i < query.size(); ++i) query_words[i] = Load(query[i].descriptor);
#ifdef G6D_HAVE_AVX512_MATCH
  const bool avx512 = options.simd && options.simd_avx512 && CpuHasAvx512Popcount();
  const bool avx2 = options.simd && !avx512 && CpuHasAvx2();
  const QueryPlanes query_planes = avx512 || avx2 ? MakeQueryPlanes(query_words) : QueryPlanes();
#endif

  const int num_templates = static_cast<int>(bank.templates.size());
  std::vector<CorrespondenceSet> all(static_cast<size_t>(num_templates));
  executor->ParallelFor(num_templates, [&](int j) {
    const Template& tmpl = bank.templates[static_cast<size_t>(j)];
    std::vector<Words> template_words(tmpl.descriptors.size());
    for (size_t k = 0; k < tmpl.descriptors.size(); ++k) template_words[k] = Load(tmpl.descriptors[k]);
    std::vector<int> best_distance(query_words.size()), best_index(query_words.size());
#ifdef G6D_HAVE_AVX512_MATCH
    if (avx512) {
      NearestDescriptorsAvx512(query_planes, template_words, best_distance.data(), best_index.data());
    } else if (avx2) {
      NearestDescriptorsAvx2(query_planes, template_words, best_distance.data(), best_index.data());
    } else {
      NearestDescriptors(query_words, template_words, best_distance.data(), best_index.data());
    }
#else
    NearestDescriptors(query_words, template_words, best_distance.data(), best_index.data());
#endif
    CorrespondenceSet& set = all[static_cast<size_t>(j)];
    set.template_index = j;
    for (size_t i = 0; i < query_words.size(); ++i) {
      const int best = best_distance[i];
      if (best_index[i] >= 0 && best < options.hamming_threshold) {  // C_j, eq. (correspondences)
        set.quality += 1.0 - static_cast<double>(best) / options.hamming_threshold;  // Q_j, eq. (4)
        set.image_points.emplace_back(query[i].xy.x() + kOpenCvToImage, query[i].xy.y() + kOpenCvToImage);
        set.object_points.push_back(tmpl.points[static_cast<size_t>(best_index[i])].cast<double>());
        set.distances.push_back(best);
        set.query_indices.push_back(static_cast<int>(i));
      }
    }
  });
  std::vector<int> order;
  for (int j = 0; j < num_templates; ++j) {
    if (all[static_cast<size_t>(j)].image_points.size() >= static_cast<size_t>(options.min_correspondences)) {
      order.push_back(j);
    }
  }
  report->templates_with_matches = static_cast<int>(order.size());
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return all[static_cast<size_t>(a)].quality > all[static_cast<size_t>(b)].quality;
  });
  if (order.size() > static_cast<size_t>(options.max_sets)) order.resize(static_cast<size_t>(options.max_sets));
  sets->reserve(order.size());
  for (int j : order) sets->push_back(std::move(all[static_cast<size_t>(j)]));
  report->sets_kept = static_cast<int>(sets->size());
  if (sets->empty()) {
    report->message = "no template has " + std::to_string(options.min_correspondences) +
                      " matches with Hamming distance < " + std::to_string(options.hamming_threshold);
    return;
  }
  report->best_quality = sets->front().quality;
  report->success = true;
  report->message = "ok";
}

}  // namespace g6d
