// OpenEXR writing and reading through OpenEXR's own library, atomically (airmass/atomic_file.hpp).
// OpenEXR rather than OpenImageIO: the CLI links these files, and OpenImageIO's
// plugins pull ≈ 240 shared libraries into every process start (≈ 0.3 s of dynamic linking
// for `airmass --version`; docs/sky.md "Start-up"), for a format OpenEXR writes alone.
#include "airmass/image_io.hpp"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfCompression.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringAttribute.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <memory>
#include <thread>
#include <utility>

#include <cctype>
#include <stdexcept>

namespace airmass {

namespace fs = std::filesystem;

namespace {

// The EXR's file stream, through a 1-MiB buffer. OpenEXR's own (a std::ofstream) hands each
// scanline to the kernel as it comes — libstdc++ writes any piece over 1 KiB straight through —
// 256 system calls for a 512 × 256 sky; here a sky up to 1 MiB is one.
class BufferedOStream final : public Imf::OStream {
public:
    explicit BufferedOStream(const fs::path& path)
        : Imf::OStream(path.c_str()), buffer_(new char[kBuffer]), file_(std::fopen(path.c_str(), "wb")) {
        if (!file_) fail("cannot open");
        std::setvbuf(file_, buffer_.get(), _IOFBF, kBuffer);  // without it: the stdio buffer
    }
    ~BufferedOStream() override {
        if (file_) std::fclose(file_);
    }
    void write(const char c[], int n) override {
        if (n > 0 && std::fwrite(c, 1, std::size_t(n), file_) != std::size_t(n)) fail("write failed");
        pos_ += uint64_t(std::max(n, 0));
    }
    // The position written to, kept here: OpenEXR's OutputFile destructor asks it outside its
    // own error handling, where a throw would end the process.
    uint64_t tellp() override { return pos_; }
    void seekp(uint64_t pos) override {
        if (fseeko(file_, off_t(pos), SEEK_SET) != 0) fail("seek failed");
        pos_ = pos;
    }
    // Flushes and closes: the errors a destructor would swallow, and those of writes whose
    // errors OpenEXR's destructor swallowed (the stream's error flag).
    void close() {
        const bool failed = std::fflush(file_) != 0 || std::ferror(file_);
        const int saved = errno;
        std::FILE* f = std::exchange(file_, nullptr);
        if (std::fclose(f) != 0 || failed) {
            if (failed) errno = saved;
            fail("write failed");
        }
    }

private:
    static constexpr std::size_t kBuffer = std::size_t(1) << 20;
    [[noreturn]] void fail(const char* what) const {
        throw std::runtime_error(std::string(what) + " (" + std::strerror(errno) + ")");
    }
    std::unique_ptr<char[]> buffer_;  // before file_: the stream's buffer outlives it
    std::FILE* file_;
    uint64_t pos_ = 0;
};

}  // namespace

void check_exr_destination(const fs::path& path) {
    if (path.empty()) throw ImageWriteError("output path is empty");
    std::string ext = path.extension().string();
    for (auto& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (ext != ".exr")
        throw ImageWriteError("output '" + path.string() + "': must end in .exr (OpenEXR is the only format written)");
    try {
        check_output_destination(path);
    } catch (const FileWriteError& e) {
        throw ImageWriteError(e.what());
    }
}

const char* exr_compression_name(ExrCompression compression) {
    switch (compression) {
        case ExrCompression::none: return "none";
        case ExrCompression::zip: return "zip";
        case ExrCompression::piz: return "piz";
    }
    return "none";
}

ExrCompression exr_compression_from_name(const std::string& name) {
    for (ExrCompression c : {ExrCompression::none, ExrCompression::zip, ExrCompression::piz})
        if (name == exr_compression_name(c)) return c;
    throw std::invalid_argument("EXR compression '" + name + "': must be none, zip or piz");
}

void write_exr_atomic(const fs::path& path, const FloatImage& image, const ImageMetadata& metadata,
                      const CancelFlag* cancel, ExrCompression compression) {
    check_exr_destination(path);
    if (image.width <= 0 || image.height <= 0 || image.channels < 1 || image.channels > 4 ||
        image.pixels.size() != std::size_t(image.width) * image.height * image.channels)
        throw ImageWriteError("output '" + path.string() + "': inconsistent image (" + std::to_string(image.width) +
                              "x" + std::to_string(image.height) + "x" + std::to_string(image.channels) + ")");

    static const char* const kNames[4][4] = {{"Y"}, {"Y", "A"}, {"R", "G", "B"}, {"R", "G", "B", "A"}};
    try {
        AtomicOutputs outputs(cancel);  // removes the temporary on any failure
        const fs::path tmp = outputs.add(path);
        try {
            Imf::Header header(image.width, image.height);
            header.compression() = compression == ExrCompression::zip   ? Imf::ZIP_COMPRESSION
                                   : compression == ExrCompression::piz ? Imf::PIZ_COMPRESSION
                                                                        : Imf::NO_COMPRESSION;
            for (const auto& [key, value] : metadata) header.insert(key, Imf::StringAttribute(value));
            Imf::FrameBuffer frame;
            const std::size_t px = sizeof(float) * std::size_t(image.channels);
            for (int c = 0; c < image.channels; ++c) {
                header.channels().insert(kNames[image.channels - 1][c], Imf::Channel(Imf::FLOAT));
                frame.insert(kNames[image.channels - 1][c],
                             Imf::Slice(Imf::FLOAT,
                                        reinterpret_cast<char*>(const_cast<float*>(image.pixels.data() + c)), px,
                                        px * std::size_t(image.width)));
            }
            {
                // Compressed by as many threads as the machine has (ZIP of a 2048 × 1024 float
                // image takes ≈ 0.8 s on one core).
                BufferedOStream stream(tmp);
                {
                    Imf::OutputFile file(stream, header, int(std::max(1u, std::thread::hardware_concurrency())));
                    file.setFrameBuffer(frame);
                    file.writePixels(image.height);
                }
                stream.close();
            }
            // OutputFile writes its line-offset table in its destructor, which swallows errors
            // (a full disk there would leave a file without it): read the table back.
            if (!Imf::InputFile(tmp.c_str()).isComplete()) throw std::runtime_error("the file is incomplete");
        } catch (const std::exception& e) {
            throw ImageWriteError("output '" + path.string() + "': writing '" + tmp.string() + "' failed: " + e.what());
        }
        outputs.commit();
    } catch (const FileWriteError& e) {
        throw ImageWriteError(e.what());
    }
}

FloatImage read_image(const fs::path& path, ImageMetadata* metadata) {
    try {
        Imf::InputFile in(path.c_str());
        const Imf::Header& header = in.header();
        const Imath::Box2i dw = header.dataWindow();
        const int width = dw.max.x - dw.min.x + 1, height = dw.max.y - dw.min.y + 1;
        // Channels in the order the writer above uses (R, G, B, A or Y, A), else the file's order.
        static const char* const kOrders[2][4] = {{"R", "G", "B", "A"}, {"Y", "A", nullptr, nullptr}};
        std::vector<std::string> names;
        for (const auto& order : kOrders) {
            if (!header.channels().findChannel(order[0])) continue;
            for (int k = 0; k < 4 && order[k]; ++k)
                if (header.channels().findChannel(order[k])) names.emplace_back(order[k]);
            break;
        }
        if (names.empty())
            for (auto it = header.channels().begin(); it != header.channels().end(); ++it) names.emplace_back(it.name());
        FloatImage image(width, height, int(names.size()));
        const std::size_t px = sizeof(float) * names.size();
        Imf::FrameBuffer frame;
        for (std::size_t c = 0; c < names.size(); ++c) {
            char* base = reinterpret_cast<char*>(image.pixels.data() + c) -
                         (std::ptrdiff_t(dw.min.x) + std::ptrdiff_t(dw.min.y) * width) * std::ptrdiff_t(px);
            frame.insert(names[c], Imf::Slice(Imf::FLOAT, base, px, px * std::size_t(width)));
        }
        in.setFrameBuffer(frame);
        in.readPixels(dw.min.y, dw.max.y);
        if (metadata) {
            metadata->clear();
            for (auto it = header.begin(); it != header.end(); ++it)
                if (const auto* text = dynamic_cast<const Imf::StringAttribute*>(&it.attribute()))
                    metadata->emplace_back(it.name(), text->value());
        }
        return image;
    } catch (const std::exception& e) {
        throw ImageWriteError("cannot read '" + path.string() + "': " + e.what());
    }
}

}  // namespace airmass
