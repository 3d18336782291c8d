// libFuzzer target: a range image's TIFF bytes (eval::decodeRangeTiff: cv::imdecode, then the
// pixel type and every range checked). Contract: the bytes decode to a float32 image of ranges
// >= 0 or NaN, or ScanError with one line naming the file; what decodes, written back as the scan
// stage writes it (a float32 TIFF), decodes to the same bits (docs/fuzzing.md).
#include <opencv2/imgcodecs.hpp>

#include <cstring>
#include <string>
#include <vector>

#include "eval/scenario/scan_reader.hpp"
#include "fuzz_support.hpp"

namespace {
const std::string kFile = "scans/view_0_range.tiff";
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace ambler;
  perception::Raster<float> range;
  try {
    range = eval::decodeRangeTiff(fuzz::text(data, size), kFile);
  } catch (const eval::ScanError& e) {
    fuzz::checkMessage(e, kFile);
    return 0;
  }
  if (range.size() > (1 << 20)) return 0;  // the round trip only for images of a sensor's size
  std::vector<uchar> bytes;
  const cv::Mat m(int(range.rows()), int(range.cols()), CV_32FC1, range.data());
  if (!cv::imencode(".tiff", m, bytes)) fuzz::finding("cannot encode an accepted image");
  try {
    const auto back = eval::decodeRangeTiff(std::string(bytes.begin(), bytes.end()), kFile);
    if (back.rows() != range.rows() || back.cols() != range.cols() ||
        std::memcmp(back.data(), range.data(), sizeof(float) * std::size_t(range.size())) != 0)
      fuzz::finding("range TIFF does not read back the same bits");
  } catch (const eval::ScanError& e) {
    fuzz::finding(std::string("the writer's TIFF of an accepted image is refused: ") + e.what());
  }
  return 0;
}
