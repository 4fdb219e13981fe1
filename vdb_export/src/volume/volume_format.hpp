// Formatting shared by the volume layer and the OpenVDB writer: numbers in messages, the
// JSON form of a density profile, phase names. docs/vdb.md documents every value.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

#include "airmass/volume.hpp"

namespace airmass::detail {

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

// A voxel size that would bring a cost scaling as v^−exponent down by `ratio`, with unit.
std::string suggest_voxel(const VdbLayout& layout, double ratio, double exponent);

}  // namespace airmass::detail
