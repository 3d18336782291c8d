// libFuzzer target: a range scan's meta JSON (eval::parseScanMeta). Contract: the text parses, or
// ScanError with one line naming the file; what parses, written back by the scan stage's writer
// (eval::scanMeta), parses to the same angles and position (docs/fuzzing.md).
#include <bit>
#include <string>

#include "eval/scenario/scan_reader.hpp"
#include "fuzz_support.hpp"

namespace {
const std::string kFile = "scans/view_0_meta.json";

bool same(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::bit_cast<std::uint64_t>(a[i]) != std::bit_cast<std::uint64_t>(b[i])) return false;
  return true;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace ambler;
  eval::ScanMeta meta;
  try {
    meta = eval::parseScanMeta(fuzz::text(data, size), kFile);
  } catch (const eval::ScanError& e) {
    fuzz::checkMessage(e, kFile);
    return 0;
  }
  perception::RangeImage image;
  image.phi = meta.phi;
  image.theta = meta.theta;
  try {
    const eval::ScanMeta back = eval::parseScanMeta(eval::scanMeta(image, meta.view).dump(2), kFile);
    if (!same(back.phi, meta.phi) || !same(back.theta, meta.theta) ||
        !same({back.view.xyz_m.x(), back.view.xyz_m.y(), back.view.xyz_m.z()},
              {meta.view.xyz_m.x(), meta.view.xyz_m.y(), meta.view.xyz_m.z()}))
      fuzz::finding("scan meta does not read back the same");
  } catch (const eval::ScanError& e) {
    fuzz::finding(std::string("the writer's meta of an accepted meta is refused: ") + e.what());
  }
  return 0;
}
