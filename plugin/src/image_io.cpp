// OpenEXR writing through OpenImageIO, atomically (airmass/atomic_file.hpp).
#include "airmass/image_io.hpp"

#include <OpenImageIO/imageio.h>

#include <cctype>

namespace airmass {

namespace fs = std::filesystem;

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

void write_exr_atomic(const fs::path& path, const FloatImage& image, const ImageMetadata& metadata,
                      const CancelFlag* cancel) {
    check_exr_destination(path);
    if (image.width <= 0 || image.height <= 0 || image.channels < 1 || image.channels > 4 ||
        image.pixels.size() != std::size_t(image.width) * image.height * image.channels)
        throw ImageWriteError("output '" + path.string() + "': inconsistent image (" + std::to_string(image.width) +
                              "x" + std::to_string(image.height) + "x" + std::to_string(image.channels) + ")");

    OIIO::ImageSpec spec(image.width, image.height, image.channels, OIIO::TypeDesc::FLOAT);
    static const char* const kNames[4][4] = {{"Y"}, {"Y", "A"}, {"R", "G", "B"}, {"R", "G", "B", "A"}};
    spec.channelnames.assign(kNames[image.channels - 1], kNames[image.channels - 1] + image.channels);
    spec.alpha_channel = image.channels == 4 ? 3 : -1;
    spec.attribute("compression", "zip");
    spec.attribute("oiio:ColorSpace", "Linear");
    for (const auto& [key, value] : metadata) spec.attribute(key, value);

    try {
        AtomicOutputs outputs(cancel);  // removes the temporary on any failure
        const fs::path tmp = outputs.add(path);
        auto fail = [&](const std::string& what) { throw ImageWriteError("output '" + path.string() + "': " + what); };
        {
            // The plugin is chosen from the destination's extension; the data goes to the temporary.
            auto out = OIIO::ImageOutput::create(path.string());
            if (!out) fail("no OpenEXR writer: " + OIIO::geterror());
            if (!out->open(tmp.string(), spec)) fail("cannot open '" + tmp.string() + "': " + out->geterror());
            if (!out->write_image(OIIO::TypeDesc::FLOAT, image.pixels.data())) {
                const std::string err = out->geterror();
                out->close();
                fail("writing failed: " + err);
            }
            if (!out->close()) fail("closing failed: " + out->geterror());
        }
        outputs.commit();
    } catch (const FileWriteError& e) {
        throw ImageWriteError(e.what());
    }
}

FloatImage read_image(const fs::path& path, ImageMetadata* metadata) {
    auto in = OIIO::ImageInput::open(path.string());
    if (!in) throw ImageWriteError("cannot read '" + path.string() + "': " + OIIO::geterror());
    const OIIO::ImageSpec& spec = in->spec();
    FloatImage image(spec.width, spec.height, spec.nchannels);
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, image.pixels.data()))
        throw ImageWriteError("cannot read '" + path.string() + "': " + in->geterror());
    if (metadata) {
        metadata->clear();
        for (const auto& p : spec.extra_attribs)
            if (p.type() == OIIO::TypeDesc::STRING) metadata->emplace_back(p.name().string(), p.get_string());
    }
    in->close();
    return image;
}

}  // namespace airmass
