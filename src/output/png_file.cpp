#include "output/png_file.hpp"

#include <png.h>

#include <vector>

#include "core/error.hpp"
#include "output/output_dir.hpp"

namespace biodem::output {

void write_png(const std::string& path, int width, int height, PngPixels pixels, const std::uint8_t* data,
               std::size_t stride) {
  if (width <= 0 || height <= 0 || data == nullptr) throw Error(path + ": cannot write an empty image");
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = pixels == PngPixels::grey ? PNG_FORMAT_GRAY : PNG_FORMAT_BGR;
  const auto row_stride = static_cast<png_int_32>(stride);
  // First call: the size the encoded file needs; second: the encoding.
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&image, nullptr, &size, 0, data, row_stride, nullptr) || size == 0) {
    const std::string why = image.message;
    png_image_free(&image);
    throw Error(path + ": cannot encode PNG: " + why);
  }
  std::string bytes(size, '\0');
  if (!png_image_write_to_memory(&image, bytes.data(), &size, 0, data, row_stride, nullptr)) {
    const std::string why = image.message;
    png_image_free(&image);
    throw Error(path + ": cannot encode PNG: " + why);
  }
  png_image_free(&image);
  bytes.resize(size);
  write_file_atomic(path, bytes);
}

}  // namespace biodem::output
