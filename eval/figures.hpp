#pragma once
// Pictures people would rather look at than read: shaded relief of a terrain, range images.
#include <opencv2/core.hpp>
#include <string>

#include "eval/io.hpp"
#include "perception/range_image.hpp"

namespace ambler::eval {

// Hill-shaded relief (sun from the north-west, 45° up) tinted by elevation, north up; NaN cells
// dark grey. A scale bar of elevation is drawn along the bottom.
cv::Mat shadedRelief(const FloatRaster& z, double cell_m, const std::string& title);

// A range image in false colour (near = warm... far = cool), no return black; pixels stretched
// so the picture keeps the angular aspect ratio; a range scale along the bottom.
cv::Mat rangePicture(const perception::RangeImage& image, double max_range_m, const std::string& title);

}  // namespace ambler::eval
