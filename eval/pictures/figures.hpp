#pragma once
// Pictures people would rather look at than read: shaded relief of a terrain, range images.
#include <opencv2/core.hpp>
#include <string>

#include "eval/scenario/io.hpp"
#include "perception/range_image.hpp"

namespace ambler::eval {

// Hill-shaded relief (sun from the north-west, 45° up) tinted by elevation, north up; NaN cells
// dark grey. A scale bar of elevation is drawn along the bottom.
cv::Mat shadedRelief(const perception::Raster<float>& z, double cell_m, const std::string& title);

// shadedRelief's picture before framing: one BGR pixel per raster cell (NaN cells dark grey), and
// the elevations [lo, hi] its colours span.
struct Relief {
  cv::Mat image;
  double lo = 0, hi = 0;
};
Relief reliefImage(const perception::Raster<float>& z, double cell_m);

// The 256 colours of an OpenCV colour map (cv::COLORMAP_*) as a 1×256 BGR image.
cv::Mat colourRamp(int colormap);

// A diverging blue–white–red ramp (Moreland's cool-warm ends) of `levels` colours as a 1×levels
// BGR image: level i at t = 2i/(levels − 1) − 1, white (247, 247, 247) blended linearly towards
// blue (192, 76, 59) for t < 0 and red (38, 4, 180) for t > 0, each channel rounded. With an odd
// count the middle level is exactly white. For signed differences: negative blue, positive red.
cv::Mat coolWarmRamp(int levels = 256);

// The integer factor by which the map pictures enlarge a raster of rows × cols cells
// (nearest neighbour, every cell a crisp square): the smallest that makes it at least 600 px
// wide, less while the picture would be taller than 2400 px; at least 1.
int cellEnlargement(int rows, int cols);

// `picture` with `title` above and, below, a colour scale (a 1×N BGR ramp stretched to fit) whose
// ends are labelled `lo` and `hi` in `unit` ("%.2f unit"). The canvas is at least 360 px wide.
cv::Mat framePicture(const cv::Mat& picture, const std::string& title, const cv::Mat& ramp, double lo,
                     double hi, const char* unit);

// A range image in false colour (near = warm... far = cool), no return black; pixels stretched
// so the picture keeps the angular aspect ratio; a range scale along the bottom.
cv::Mat rangePicture(const perception::RangeImage& image, double max_range_m, const std::string& title);

}  // namespace ambler::eval
