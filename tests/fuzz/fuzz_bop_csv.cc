// libFuzzer harness: ReadBopCsv() (lib/eval/bop_csv.h) on the input as a results file.
// Only g6d::Error is caught. A file that parses must also survive WriteBopCsv() and a
// second read with the same values (the round trip bop_csv.h promises); a failure there,
// even a g6d::Error, escapes and is a finding.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.h"
#include "eval/bop_csv.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<g6d::BopEstimate> estimates;
  try {
    std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
    estimates = g6d::ReadBopCsv(in, "fuzz.csv");
  } catch (const g6d::Error&) {
    return 0;
  }
  std::ostringstream written;
  g6d::WriteBopCsv(estimates, &written);
  std::istringstream again(written.str());
  const std::vector<g6d::BopEstimate> reread = g6d::ReadBopCsv(again, "fuzz round trip");
  G6D_CHECK(reread.size() == estimates.size());
  for (size_t i = 0; i < estimates.size(); ++i) {
    const g6d::BopEstimate& a = estimates[i];
    const g6d::BopEstimate& b = reread[i];
    G6D_CHECK(a.scene_id == b.scene_id && a.im_id == b.im_id && a.obj_id == b.obj_id);
    G6D_CHECK(a.score == b.score && a.time_s == b.time_s);
    G6D_CHECK(a.cam_from_object.linear() == b.cam_from_object.linear());
    // t goes through one m -> mm -> m conversion: equal to a few ulps.
    for (int k = 0; k < 3; ++k) {
      const double ta = a.cam_from_object.translation()[k];
      const double tb = b.cam_from_object.translation()[k];
      G6D_CHECK(std::abs(ta - tb) <= 1e-12 * std::abs(ta) + 1e-300);
    }
  }
  return 0;
}
