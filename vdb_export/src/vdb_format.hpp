// What vdb_export writes, in one place: metadata keys and values, the JSON form of a
// density profile, number formatting. docs/vdb.md documents every key listed here.
#pragma once

#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>

#include <string>

#include "airmass/vdb_grids.hpp"

namespace airmass::detail {

// Version of the grid/metadata layout (airmass:format_version); bump on any change a
// reader must know about.
inline constexpr int kVdbFormatVersion = 1;

// Short human form of a number ("%.6g").
std::string fmt(double x);
// Mebibytes with one decimal.
std::string mib(double bytes);

// The profile as JSON with altitudes in the layout's unit:
//   {"type":"exponential","scale_height":H,"reference_altitude":h0}
//   {"type":"tent","bottom":b,"peak":p,"top":t}
//   {"type":"piecewise_linear","knots":[[h,rho],...]}
//   {"type":"constant","value":v,"bottom":b,"top":t|null}
nlohmann::json profile_json(const DensityProfile& p, double metres_per_unit);

std::string phase_name(PhaseFunction::Kind k);

// Metadata common to every grid and to the file (unit, planet, basis, version...).
void add_common_metadata(openvdb::MetaMap& m, const VdbLayout& layout);
// Grid metadata: the common keys plus the constituent's profile, coefficients, phase
// and the tile it belongs to.
void add_grid_metadata(openvdb::MetaMap& m, const VdbLayout& layout, const VdbConstituent& c, std::size_t tile,
                       std::size_t tile_count);
// File metadata: the common keys plus the scene (airmass:scene, JSON).
openvdb::MetaMap::Ptr file_metadata(const VdbLayout& layout, std::size_t tile, std::size_t tile_count);

}  // namespace airmass::detail
