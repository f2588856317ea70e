// SPDX-License-Identifier: Apache-2.0
// What the rockvdb extension's translation units share: the Task host that turns Ctrl-C into
// cancellation, parameter JSON from the Python wrappers, and how provenance names a grid input.
#pragma once

#include <rockvdb/blocks/BlockTile.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/Json.h>
#include <rockvdb/core/Schema.h>
#include <rockvdb/core/StageResult.h>
#include <rockvdb/core/Task.h>
#include <rockvdb/core/VdbIO.h>

#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>
#include <pybind11/pybind11.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

namespace py = pybind11;

namespace rockvdb {
namespace pyhost {

/// A level set (or id grid) as the bindings pass it; None is refused by GridCaster.h.
using Grid = openvdb::FloatGrid::Ptr;

/// A call that another Python thread watches and may cancel (rockvdb.Job): a front-end that
/// runs a stage off its UI thread (the Blender add-on) reads the progress and cancels.
struct PyJob
{
    std::atomic<bool> cancelled{false};
    std::atomic<double> progress{0.0};
    std::mutex mutex; ///< guards phase
    std::string phase;
};

/// The job entered (`with job:`) on this thread, if any: the calls this thread makes report
/// to it and stop when it is cancelled.
inline thread_local std::shared_ptr<PyJob> tCurrentJob;

/// A Task's host in Python: Ctrl-C (the interpreter's pending SIGINT, or any signal whose
/// handler raises) cancels; polled from the calling thread, which works in every TBB loop, at
/// most every 50 ms, with the GIL taken just for the check. Stages then raise
/// KeyboardInterrupt. Python delivers signals to the main thread only: calls from other
/// Python threads run to the end, unless they run in a rockvdb.Job that is cancelled.
class PyTaskHost : public TaskHost
{
public:
    bool cancelled() override
    {
        if (mJob && mJob->cancelled.load()) mCancelled.store(true);
        if (mCancelled.load()) return true;
        if (std::this_thread::get_id() != mCaller) return false;
        const auto now = std::chrono::steady_clock::now();
        if (now < mNext) return false;
        mNext = now + std::chrono::milliseconds(50);
        pybind11::gil_scoped_acquire gil;
        if (PyErr_CheckSignals() != 0) {
            PyErr_Clear(); // raised again as KeyboardInterrupt by the Interrupted translator
            mCancelled.store(true);
        }
        return mCancelled.load();
    }

    void progress(const char* phase, double fraction) override
    {
        if (!mJob) return;
        {
            std::lock_guard<std::mutex> lock(mJob->mutex);
            mJob->phase = phase;
        }
        mJob->progress.store(fraction);
    }

private:
    std::shared_ptr<PyJob> mJob = tCurrentJob;
    std::thread::id mCaller = std::this_thread::get_id();
    std::chrono::steady_clock::time_point mNext{};
    std::atomic<bool> mCancelled{false};
};

/// @brief @a work(task) with the GIL released and a Task that Python's Ctrl-C cancels: how
/// every binding calls an entry point.
template<typename Work>
auto withTask(Work&& work)
{
    pybind11::gil_scoped_release release;
    PyTaskHost host;
    Task task(&host);
    return work(task);
}

/// A field plus the expression that rebuilds it (its provenance): rockvdb.Field's native half.
struct PyField
{
    FieldPtr field;
    nlohmann::json expr;
};

/// A generated or loaded block tile: rockvdb.BlockTile's native half.
struct PyTile
{
    std::shared_ptr<const blocks::BlockTile> tile;
};

/// A stage result's stats (JSON) as a Python dict.
inline pybind11::object pyJson(const nlohmann::json& j)
{
    return pybind11::module_::import("json").attr("loads")(jsonText(j));
}

/// The JSON text of a Python call's parameters (the wrapper spells keys as the CLI does).
inline nlohmann::json parseParams(const std::string& text, const char* op)
{
    nlohmann::json j = parseJson(text, std::string(op) + ": parameters");
    return j;
}

/// The bindings, one file per part; module.cc calls them in this order.
void bindFields(pybind11::module_& m);   ///< rockvdb.Field, primitives, heightfield (fields.cc)
void bindGrids(pybind11::module_& m);    ///< CSG, read / write, mesh, preview, images (grids.cc)
void bindBlocks(pybind11::module_& m);   ///< rockvdb.BlockTile, the block-tile stage (blocks.cc)
void bindAmplify(pybind11::module_& m);  ///< the amplify stage (amplify.cc)
void bindDetail(pybind11::module_& m);   ///< the detail stage (detail.cc)
void bindRockpile(pybind11::module_& m); ///< rock tiles and piles (rockpile.cc)
void bindAsset(pybind11::module_& m);    ///< game assets, GLB (asset.cc)

/// rockvdb.fractal_rock / fractal_scatter / fractal_carve's native half (fractal.cc).
void bindFractal(pybind11::module_& m);

/// rockvdb.Stacks' native half (arches.cc) and the arches table's description.
void bindArches(pybind11::module_& m);
const SchemaBase& archesSchemaBase();
std::string archesEditTools();

} // namespace pyhost
} // namespace rockvdb
