// Tile extraction and contact sheets for rendered image batches.
#include <algorithm>
#include <cmath>

#include "duolod/render.hpp"

namespace duolod::render {

core::ImageRGBA8 tileImage(const ImageBatch8& batch, int index) {
  core::ImageRGBA8 image{batch.width, batch.height, {}};
  const uint8_t* tile = batch.tile(index);
  image.pixels.assign(tile, tile + size_t(batch.width) * batch.height * 4);
  return image;
}

core::ImageRGBA8 tileImage(const ImageBatchF& batch, int index) {
  core::ImageRGBA8 image{batch.width, batch.height, {}};
  const float* tile = batch.tile(index);
  size_t n = size_t(batch.width) * batch.height * 4;
  image.pixels.resize(n);
  for (size_t i = 0; i < n; ++i)
    image.pixels[i] = static_cast<uint8_t>(std::lround(std::clamp(tile[i], 0.0f, 1.0f) * 255.0f));
  return image;
}

core::ImageRGBA8 contactSheet(const ImageBatch8& batch, int columns) {
  columns = std::max(1, std::min(columns, batch.count));
  int rows = (batch.count + columns - 1) / columns;
  core::ImageRGBA8 sheet;
  sheet.width = columns * (batch.width + 1) - 1;
  sheet.height = rows * (batch.height + 1) - 1;
  sheet.pixels.assign(size_t(sheet.width) * sheet.height * 4, 40);  // dark grey gaps
  for (int i = 0; i < batch.count; ++i) {
    int x0 = (i % columns) * (batch.width + 1), y0 = (i / columns) * (batch.height + 1);
    const uint8_t* tile = batch.tile(i);
    for (int y = 0; y < batch.height; ++y)
      std::copy_n(tile + size_t(y) * batch.width * 4, batch.width * 4,
                  sheet.pixels.data() + (size_t(y0 + y) * sheet.width + x0) * 4);
  }
  return sheet;
}

}  // namespace duolod::render
