// Writing linear float images as OpenEXR, atomically.
//
// An image is written to a temporary file beside the destination (same directory, so
// the final rename(2) is atomic on one filesystem) and renamed over the destination
// only once OpenImageIO has closed it without error. A reader therefore sees either
// the previous file or the complete new one, never a partial file; on any failure the
// temporary is removed and nothing else is touched.
#pragma once

#include <cstddef>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace airmass {

// Every problem writing an image; the message names the path and the cause.
struct ImageWriteError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// A linear float image, rows top to bottom, channels interleaved (R, G, B, ...).
struct FloatImage {
    int width = 0;
    int height = 0;
    int channels = 3;
    std::vector<float> pixels;  // width · height · channels

    FloatImage() = default;
    FloatImage(int w, int h, int c) : width(w), height(h), channels(c), pixels(std::size_t(w) * h * c, 0.0f) {}
    float* row(int y) { return pixels.data() + std::size_t(y) * width * channels; }
    const float* row(int y) const { return pixels.data() + std::size_t(y) * width * channels; }
    float* at(int x, int y) { return row(y) + std::size_t(x) * channels; }
    const float* at(int x, int y) const { return row(y) + std::size_t(x) * channels; }
};

// String attributes stored in the EXR header, e.g. {"airmass:version", "0.1.0"}.
using ImageMetadata = std::vector<std::pair<std::string, std::string>>;

// Checks, before any expensive work, that `path` can be written: it ends in ".exr",
// its directory exists and is writable. Throws ImageWriteError naming the problem.
void check_exr_destination(const std::filesystem::path& path);

// Writes `image` as a 32-bit float, ZIP-compressed scanline EXR with channels R, G, B
// (A for a fourth), plus `metadata`, via temporary file + rename. Throws ImageWriteError.
void write_exr_atomic(const std::filesystem::path& path, const FloatImage& image, const ImageMetadata& metadata);

// Reads an image as 32-bit float (any format OpenImageIO reads), with its string
// attributes. For tests and reports. Throws ImageWriteError (naming the path) on failure.
FloatImage read_image(const std::filesystem::path& path, ImageMetadata* metadata = nullptr);

// The temporary name write_exr_atomic uses for `path` in this process (for tests and
// for documentation: "<dir>/.<name>.airmass-tmp-<pid>.exr").
std::filesystem::path exr_temporary_path(const std::filesystem::path& path);

}  // namespace airmass
