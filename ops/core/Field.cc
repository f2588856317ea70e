#include "Field.h"

#include <algorithm>
#include <cmath>

namespace rockvdb {

bool isBounded(const BBoxd& b)
{
    for (int i = 0; i < 3; ++i) {
        if (!std::isfinite(b.min()[i]) || !std::isfinite(b.max()[i])) return false;
        if (std::abs(b.min()[i]) > 1e15 || std::abs(b.max()[i]) > 1e15) return false;
    }
    return true;
}

void Field::evalIdBatch(const Batch& b, float* out, float* id) const
{
    evalBatch(b, out);
    std::fill(id, id + b.n, kNoId);
}

float Field::eval(const Vec3d& p) const
{
    const float x = float(p[0]), y = float(p[1]), z = float(p[2]);
    float out;
    evalBatch(Batch{&x, &y, &z, 1, Vec3f(x, y, z), 0.0f}, &out);
    return out;
}

float Field::evalId(const Vec3d& p, float* id) const
{
    const float x = float(p[0]), y = float(p[1]), z = float(p[2]);
    float out;
    evalIdBatch(Batch{&x, &y, &z, 1, Vec3f(x, y, z), 0.0f}, &out, id);
    return out;
}

} // namespace rockvdb
