// PNG files from 8-bit images (frames, plots, overlays), written atomically with libpng's
// simplified API. Independent of OpenCV, so that writing a PNG does not load OpenCV's image
// codecs (about 120 shared libraries: a tenth of a second at every start of the program).
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>

namespace biodem::output {

enum class PngPixels { grey, bgr };

/// Writes a width x height image of 8-bit pixels (rows `stride` bytes apart; grey: one byte per
/// pixel, bgr: blue, green, red) as a PNG file (grey or RGB), atomically. Throws biodem::Error
/// naming the path when it cannot.
void write_png(const std::string& path, int width, int height, PngPixels pixels, const std::uint8_t* data,
               std::size_t stride);

}  // namespace biodem::output
