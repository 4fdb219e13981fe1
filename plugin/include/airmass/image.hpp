// A linear float image in memory (the sky and native renders produce it; writers in
// image_io.hpp, or the host through the C ABI, store it).
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "airmass/large_buffer.hpp"

namespace airmass {

// A linear float image, rows top to bottom, channels interleaved (R, G, B, ...).
struct FloatImage {
    int width = 0;
    int height = 0;
    int channels = 3;
    // width · height · channels; tens of MB for a sky texture, on huge pages where the system
    // offers them (large_buffer.hpp: the first touch of 4 KiB pages was a third of a warm
    // 2048 × 1024 sky's time on a virtual machine, docs/sky.md)
    std::vector<float, LargeAllocator<float>> pixels;

    FloatImage() = default;
    FloatImage(int w, int h, int c) : width(w), height(h), channels(c), pixels(std::size_t(w) * h * c, 0.0f) {}
    float* row(int y) { return pixels.data() + std::size_t(y) * width * channels; }
    const float* row(int y) const { return pixels.data() + std::size_t(y) * width * channels; }
    float* at(int x, int y) { return row(y) + std::size_t(x) * channels; }
    const float* at(int x, int y) const { return row(y) + std::size_t(x) * channels; }
};

// String attributes stored in the EXR header, e.g. {"airmass:version", "0.1.0"}.
using ImageMetadata = std::vector<std::pair<std::string, std::string>>;

}  // namespace airmass
