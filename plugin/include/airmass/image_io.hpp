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

// How an EXR's pixels are stored; every choice is lossless (the 32-bit floats read back bit
// for bit). `none` is the default: zlib is most of a large sky's time (a 2048 × 1024 sky:
// ≈ 0.02 s uncompressed, 25 MB; ≈ 0.4 s ZIP, 10 MB; `bench/exr_compression.sh`, docs/sky.md),
// and an uncompressed file also loads fastest in Blender.
enum class ExrCompression { none, zip, piz };
inline constexpr ExrCompression kDefaultExrCompression = ExrCompression::none;
// "none", "zip", "piz" (the CLI's --exr-compression); the inverse of exr_compression_from_name.
const char* exr_compression_name(ExrCompression compression);
// Throws std::invalid_argument naming the allowed values.
ExrCompression exr_compression_from_name(const std::string& name);

// Writes `image` as a 32-bit float scanline EXR (compression as given) with channels R, G, B
// (A for a fourth), plus `metadata`, via temporary file + rename. Throws ImageWriteError, or
// Cancelled when `cancel` is requested before the rename (the destination then untouched).
void write_exr_atomic(const std::filesystem::path& path, const FloatImage& image, const ImageMetadata& metadata,
                      const CancelFlag* cancel = nullptr, ExrCompression compression = kDefaultExrCompression);

// Reads an OpenEXR image as 32-bit float (channels R, G, B, A or Y, A in that order, else the
// file's), with its string attributes. For tests and reports. Throws ImageWriteError (naming the path) on failure.
FloatImage read_image(const std::filesystem::path& path, ImageMetadata* metadata = nullptr);

}  // namespace airmass
