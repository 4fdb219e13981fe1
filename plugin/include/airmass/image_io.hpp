// Writing linear float images as OpenEXR, atomically.
//
// An image is written to a temporary file beside the destination and renamed over it only
// once OpenEXR has closed it without error (airmass/atomic_file.hpp, the one helper of
// every writer). A reader therefore sees either the previous file or the complete new one,
// never a partial file; on any failure the temporary is removed and nothing else is touched.
#pragma once

#include <cstddef>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "airmass/atomic_file.hpp"
#include "airmass/image.hpp"

namespace airmass {

// Every problem writing an image; the message names the path and the cause.
struct ImageWriteError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// Checks, before any expensive work, that `path` can be written: it ends in ".exr",
// its directory exists and a file can be created there (check_output_destination).
// Throws ImageWriteError naming the problem.
void check_exr_destination(const std::filesystem::path& path);

// Writes `image` as a 32-bit float, ZIP-compressed scanline EXR with channels R, G, B
// (A for a fourth), plus `metadata`, via temporary file + rename. Throws ImageWriteError, or
// Cancelled when `cancel` is requested before the rename (the destination then untouched).
void write_exr_atomic(const std::filesystem::path& path, const FloatImage& image, const ImageMetadata& metadata,
                      const CancelFlag* cancel = nullptr);

// Reads an OpenEXR image as 32-bit float (channels R, G, B, A or Y, A in that order, else the
// file's), with its string attributes. For tests and reports. Throws ImageWriteError (naming the path) on failure.
FloatImage read_image(const std::filesystem::path& path, ImageMetadata* metadata = nullptr);

}  // namespace airmass
