// SPDX-License-Identifier: Apache-2.0
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

void Field::gradientBatch(const Batch& b, float h, float* gx, float* gy, float* gz) const
{
    BatchBuffer q;
    alignas(64) float m[kMaxBatch];
    q.n = b.n;
    q.center = b.center;
    q.radius = b.radius + h;
    q.band = b.band;
    q.reach = b.reach;
    const float inv = 0.5f / h;
    float* g[3] = {gx, gy, gz};
    for (int a = 0; a < 3; ++a) {
        for (int sign = 1; sign >= -1; sign -= 2) {
            const float s = float(sign) * h;
            for (int i = 0; i < b.n; ++i) {
                q.x[i] = b.x[i] + (a == 0 ? s : 0.0f);
                q.y[i] = b.y[i] + (a == 1 ? s : 0.0f);
                q.z[i] = b.z[i] + (a == 2 ? s : 0.0f);
            }
            evalBatch(q.view(), sign > 0 ? g[a] : m);
        }
        for (int i = 0; i < b.n; ++i) g[a][i] = (g[a][i] - m[i]) * inv;
    }
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
