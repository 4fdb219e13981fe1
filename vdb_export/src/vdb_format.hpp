// The volume layer's metadata (airmass/volume.hpp) as OpenVDB metadata.
#pragma once

#include <openvdb/openvdb.h>

#include <vector>

#include "airmass/volume.hpp"

namespace airmass::detail {

// Inserts every entry with its OpenVDB type (String, Double, Int32, Vec3D metadata).
void insert_metadata(openvdb::MetaMap& m, const std::vector<VolumeMetadatum>& entries);

}  // namespace airmass::detail
