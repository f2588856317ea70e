// rockvdb — a baked level set as a Field (e.g. a 3D terrain with overhangs from Houdini).
#pragma once

#include "Field.h"

#include <openvdb/openvdb.h>

namespace rockvdb {

/// @brief Trilinear samples of a level-set grid: a distance within its narrow band and
/// ±background beyond (a lower bound of the distance there). The band is first widened with
/// tools::dilateSdf (fast sweeping) to at least @a exactWidth metres, so callers that read
/// distances or gradients that far from the surface get real values.
/// @throw ValueError unless @a grid is a level set.
FieldPtr levelSetField(openvdb::FloatGrid::ConstPtr grid, double exactWidth = 0.0);

} // namespace rockvdb
