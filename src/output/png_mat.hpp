// write_png for OpenCV images (8-bit grey or BGR), for the parts that draw with OpenCV.
#pragma once
#include <opencv2/core.hpp>
#include <string>

#include "core/error.hpp"
#include "output/png_file.hpp"

namespace biodem::output {

inline void write_png(const std::string& path, const cv::Mat& img) {
  if (img.depth() != CV_8U || (img.channels() != 1 && img.channels() != 3))
    throw Error(path + ": internal error: PNG images here are 8-bit grey or BGR");
  write_png(path, img.cols, img.rows, img.channels() == 1 ? PngPixels::grey : PngPixels::bgr, img.ptr<std::uint8_t>(0),
            img.step[0]);
}

}  // namespace biodem::output
