// SPDX-License-Identifier: Apache-2.0
// Fuzz target: every JSON we read. The first byte picks the consumer, the rest is the text:
// a stage's --params / provenance table (each stage), an expression (built and evaluated at a
// few points), strata, fractures, authored blocks, a block tile file, a detail skeleton, an
// arches edit list, and provenance text (jsonOrText + dump, as vdb_info prints it).
#include "FuzzUtil.h"

#include <rockvdb/amplify/Amplify.h>
#include <rockvdb/amplify/AmplifyStage.h>
#include <rockvdb/arches/ArchesStage.h>
#include <rockvdb/arches/Edits.h>
#include <rockvdb/blocks/BlockTile.h>
#include <rockvdb/blocks/BlocksStage.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/detail/Detail.h>
#include <rockvdb/detail/DetailStage.h>
#include <rockvdb/fractal/FractalStage.h>
#include <rockvdb/rockpile/RockPileStage.h>

#include <nlohmann/json.hpp>

namespace {

using namespace rockvdb;
using nlohmann::json;

void expression(const json& j)
{
    ExpressionContext ctx;
    ctx.baseDir = "/nonexistent"; // a fuzzed "file" never reaches a real one
    const FieldPtr f = fieldFromJson(j, ctx);
    (void)f->bounds();
    (void)f->lipschitz();
    for (int i = 0; i < 8; ++i) {
        (void)f->eval(Vec3d((i & 1) ? 0.5 : -3.0, (i & 2) ? 0.25 : 7.0, (i & 4) ? 1e3 : 0.0));
    }
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
    if (size == 0) return 0;
    const int consumer = data[0] % 16;
    const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
    if (consumer == 15) {
        // Provenance: whatever the bytes, the embedding stays valid JSON.
        const std::string out = jsonOrText(text).dump();
        if (json::parse(out, nullptr, false).is_discarded()) std::abort();
        return 0;
    }
    fuzz::expectClean([&] {
        const json j = parseJson(text, "fuzz");
        switch (consumer) {
        case 0: (void)blocks::tileSchema().fromJson(j); break;
        case 1: (void)blocks::blocksSchema().fromJson(j); break;
        case 2: (void)amplify::amplifySchema().fromJson(j); break;
        case 3: (void)detail::DetailParams::fromJson(j); break;
        case 4: (void)rockpile::tilesSchema().fromJson(j); break;
        case 5: (void)rockpile::pileSchema().fromJson(j); break;
        case 6: (void)fractal::rockSchema().fromJson(j); break;
        case 7: (void)arches::archesSchema().fromJson(j); break;
        case 8: expression(j); break;
        case 9: (void)amplify::Strata::fromJson(j, {"granite", "sandstone"}); break;
        case 10: (void)blocks::fracturesFromJson(j); break;
        case 11: (void)blocks::authoredListFromJson(j); break;
        case 12: (void)blocks::tileFromJson(j); break;
        case 13: (void)detail::DirectionField::fromSkeletonJson(j); break;
        case 14:
            if (!j.is_array()) break;
            for (size_t i = 0; i < j.size(); ++i) arches::validateEdit(j[i], i);
            break;
        }
    });
    return 0;
}
