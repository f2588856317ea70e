// SPDX-License-Identifier: Apache-2.0
// JSON expressions (core/Expression.h): each node's field against its analytic distance, CSG
// and transforms as identities, id tags reaching the attribute, and errors naming the JSON path.
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/Random.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <string>

using namespace rockvdb;
using nlohmann::json;

namespace {

FieldPtr parseField(const std::string& text)
{
    return fieldFromJsonText(text, ExpressionContext());
}

// Random points in [-2, 2]³ (deterministic).
Vec3d point(int i)
{
    return Vec3d(random::uniform(3, 0, uint64_t(i), -2, 2), random::uniform(3, 1, uint64_t(i), -2, 2),
                 random::uniform(3, 2, uint64_t(i), -2, 2));
}

std::string errorOf(const std::string& text)
{
    try {
        parseField(text);
    } catch (const ValueError& e) {
        return e.what();
    }
    return "";
}

} // namespace

TEST(Expression, SphereBoxAndCapsuleAreTheirDistances)
{
    auto sphere = parseField(R"({"type": "sphere", "center": [0.5, 0, -0.25], "radius": 0.75})");
    auto box = parseField(R"({"type": "box", "center": [0, 0, 0], "size": [2, 1, 0.5]})");
    auto capsule = parseField(R"({"type": "capsule", "a": [-1, 0, 0], "b": [1, 0, 0], "radius": 0.3})");
    for (int i = 0; i < 500; ++i) {
        const Vec3d p = point(i);
        EXPECT_NEAR(sphere->eval(p), (p - Vec3d(0.5, 0, -0.25)).length() - 0.75, 1e-5);
        // Box of half extents h: |max(q, 0)| + min(max q, 0) with q = |p| − h.
        const Vec3d q(std::abs(p[0]) - 1.0, std::abs(p[1]) - 0.5, std::abs(p[2]) - 0.25);
        const double outside = Vec3d(std::max(q[0], 0.0), std::max(q[1], 0.0), std::max(q[2], 0.0)).length();
        EXPECT_NEAR(box->eval(p), outside + std::min(std::max(q[0], std::max(q[1], q[2])), 0.0), 1e-5);
        const double t = std::min(std::max(p[0], -1.0), 1.0);
        EXPECT_NEAR(capsule->eval(p), (p - Vec3d(t, 0, 0)).length() - 0.3, 1e-5);
    }
    EXPECT_TRUE(sphere->exact());
    const BBoxd b = sphere->bounds();
    EXPECT_LE(b.min()[0], -0.25 + 1e-6);
    EXPECT_GE(b.max()[0], 1.25 - 1e-6);
}

TEST(Expression, CsgIsMinMaxAndDifference)
{
    const std::string a = R"({"type": "sphere", "center": [-0.4, 0, 0], "radius": 0.7})";
    const std::string b = R"({"type": "sphere", "center": [0.4, 0, 0], "radius": 0.6})";
    auto fa = parseField(a), fb = parseField(b);
    auto u = parseField(R"({"type": "union", "children": [)" + a + "," + b + "]}");
    auto n = parseField(R"({"type": "intersection", "children": [)" + a + "," + b + "]}");
    auto d = parseField(R"({"type": "difference", "children": [)" + a + "," + b + "]}");
    for (int i = 0; i < 500; ++i) {
        const Vec3d p = point(i);
        const float va = fa->eval(p), vb = fb->eval(p);
        EXPECT_FLOAT_EQ(u->eval(p), std::min(va, vb));
        EXPECT_FLOAT_EQ(n->eval(p), std::max(va, vb));
        EXPECT_FLOAT_EQ(d->eval(p), std::max(va, -vb));
    }
    // A smooth union adds material where both are near (a fillet): never above the hard one.
    auto s = parseField(R"({"type": "union", "smooth": 0.3, "children": [)" + a + "," + b + "]}");
    int below = 0;
    for (int i = 0; i < 500; ++i) {
        const Vec3d p = point(i);
        EXPECT_LE(s->eval(p), u->eval(p) + 1e-6f);
        below += s->eval(p) < u->eval(p) - 1e-4f;
    }
    EXPECT_GT(below, 0);
}

TEST(Expression, TransformMovesRotatesAndScalesDistances)
{
    auto f = parseField(R"({"type": "transform", "translate": [1, 2, 3], "rotate": [0, 0, 90], "scale": 2,
                       "child": {"type": "box", "center": [0, 0, 0], "size": [1, 0.5, 0.25]}})");
    auto ref = parseField(R"({"type": "box", "center": [0, 0, 0], "size": [1, 0.5, 0.25]})");
    for (int i = 0; i < 300; ++i) {
        const Vec3d p = point(i) * 2.0 + Vec3d(1, 2, 3);
        // World → local: undo the translation, the 90° turn about z, then the scale.
        const Vec3d t = p - Vec3d(1, 2, 3);
        const Vec3d local = Vec3d(t[1], -t[0], t[2]) / 2.0;
        EXPECT_NEAR(f->eval(p), 2.0 * ref->eval(local), 1e-4);
    }
}

TEST(Expression, IdTagsReachTheAttribute)
{
    auto f = parseField(R"({"type": "union", "children": [
        {"type": "sphere", "center": [-1, 0, 0], "radius": 0.5, "id": 7},
        {"type": "sphere", "center": [1, 0, 0], "radius": 0.5, "id": 11}]})");
    float id = 0;
    f->evalId(Vec3d(-1.1, 0, 0), &id);
    EXPECT_EQ(id, 7.0f);
    f->evalId(Vec3d(0.9, 0.2, 0), &id);
    EXPECT_EQ(id, 11.0f);
}

TEST(Expression, ErrorsNameTheJsonPath)
{
    EXPECT_NE(errorOf(R"({"type": "sphere", "center": [0, 0, 0], "radius": 1, "radus": 2})").find("radus"),
              std::string::npos);
    const std::string nested = errorOf(R"({"type": "union", "children": [
        {"type": "sphere", "center": [0, 0, 0], "radius": 1},
        {"type": "sphere", "center": [0, 0], "radius": 1}]})");
    EXPECT_NE(nested.find("children/1"), std::string::npos) << nested;
    EXPECT_NE(errorOf(R"({"type": "spheer"})").find("spheer"), std::string::npos);
    EXPECT_NE(errorOf(R"({"type": "sphere", "center": [0, 0, 0], "radius": -1})"), "");
    // Malformed text: the parser's position.
    const std::string syntax = errorOf("{\"type\": \"sphere\",\n \"radius\": }");
    EXPECT_NE(syntax.find("line 2"), std::string::npos) << syntax;
}
