// The volume layer's typed metadata as OpenVDB metadata (docs/vdb.md, "Metadata").
#include "vdb_format.hpp"

#include <type_traits>
#include <variant>

namespace airmass::detail {

void insert_metadata(openvdb::MetaMap& m, const std::vector<VolumeMetadatum>& entries) {
    for (const auto& e : entries) {
        std::visit(
            [&](const auto& v) {
                using T = std::decay_t<decltype(v)>;
                if constexpr (std::is_same_v<T, std::string>) m.insertMeta(e.key, openvdb::StringMetadata(v));
                else if constexpr (std::is_same_v<T, double>) m.insertMeta(e.key, openvdb::DoubleMetadata(v));
                else if constexpr (std::is_same_v<T, std::int32_t>) m.insertMeta(e.key, openvdb::Int32Metadata(v));
                else if constexpr (std::is_same_v<T, std::array<double, 3>>)
                    m.insertMeta(e.key, openvdb::Vec3DMetadata(openvdb::Vec3d(v[0], v[1], v[2])));
                else m.insertMeta(e.key, openvdb::Vec3IMetadata(openvdb::Vec3i(v[0], v[1], v[2])));
            },
            e.value);
    }
}

}  // namespace airmass::detail
