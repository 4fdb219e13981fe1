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

#include "airmass/image.hpp"

namespace airmass {

// Every problem writing an image; the message names the path and the cause.
struct ImageWriteError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

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
