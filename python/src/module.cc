// SPDX-License-Identifier: Apache-2.0
// The rockvdb Python module's init: error translation, the stage tables the Python wrappers
// read, and one binding file per part (fields.cc, grids.cc, blocks.cc, amplify.cc, detail.cc,
// rockpile.cc, fractal.cc, arches.cc), each converting types around one entry point.
#include "GridCaster.h"
#include "Host.h"

#include <rockvdb/amplify/AmplifyStage.h>
#include <rockvdb/asset/AssetStage.h>
#include <rockvdb/blocks/BlocksStage.h>
#include <rockvdb/core/BakeParams.h>
#include <rockvdb/core/CsgStage.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/HeightfieldStage.h>
#include <rockvdb/core/Json.h>
#include <rockvdb/core/Mesh.h>
#include <rockvdb/core/Preview.h>
#include <rockvdb/core/VdbIO.h>
#include <rockvdb/detail/DetailStage.h>
#include <rockvdb/fractal/FractalStage.h>
#include <rockvdb/rockpile/RockPileStage.h>

#include <thread>

using namespace rockvdb;
using namespace rockvdb::pyhost;

// Ctrl-C while a file's bytes are checked in readGrids' child process (a corrupt file can
// keep it busy for its whole CPU budget): only the thread that imported the module, as the
// interpreter's main thread, sees Python's signals.
static std::thread::id gImportThread;

static bool pyReadInterrupt()
{
    if (tCurrentJob && tCurrentJob->cancelled.load()) return true;
    if (std::this_thread::get_id() != gImportThread || !Py_IsInitialized()) return false;
    py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() == 0) return false;
    PyErr_Clear(); // raised again as KeyboardInterrupt by the Interrupted translator
    return true;
}

PYBIND11_MODULE(_rockvdb, m)
{
    m.doc() = "rockvdb: procedural rocks as OpenVDB level sets (metres, negative inside)";
    py::module_::import("pyopenvdb");
    initialize();
    gImportThread = std::this_thread::get_id();
    setReadInterrupt(&pyReadInterrupt);

    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const ValueError& e) {
            PyErr_SetString(PyExc_ValueError, e.what());
        } catch (const IoError& e) {
            PyErr_SetString(PyExc_IOError, e.what());
        } catch (const Interrupted& e) {
            PyErr_SetString(PyExc_KeyboardInterrupt, e.what());
        } catch (const openvdb::IoError& e) {
            PyErr_SetString(PyExc_IOError, e.what());
        }
    });
    m.attr("__version__") = version();

    // rockvdb.Job: `with job:` on a worker thread, job.cancel() / job.progress from another.
    py::class_<PyJob, std::shared_ptr<PyJob>>(m, "Job")
        .def(py::init<>())
        .def("cancel", [](PyJob& j) { j.cancelled.store(true); })
        .def_property_readonly("cancelled", [](const PyJob& j) { return j.cancelled.load(); })
        .def_property_readonly("progress", [](const PyJob& j) { return j.progress.load(); })
        .def_property_readonly("phase", [](PyJob& j) {
            std::lock_guard<std::mutex> lock(j.mutex);
            return j.phase;
        })
        .def("__enter__", [](std::shared_ptr<PyJob> j) {
            if (tCurrentJob) throw ValueError("Job: this thread is already in a job");
            tCurrentJob = j;
            return j;
        })
        .def("__exit__", [](PyJob&, py::args) {
            tCurrentJob.reset();
            return false;
        });

    bindFields(m);
    bindGrids(m);
    bindBlocks(m);
    bindAmplify(m);
    bindDetail(m);
    bindRockpile(m);
    bindFractal(m);
    bindArches(m);
    bindAsset(m);

    // Stage tables: the Python wrappers build their signatures, defaults and docstrings
    // from these (python/rockvdb/__init__.py).
    m.def("schema", [](const std::string& stage) {
        if (stage == "csg") return jsonText(csgSchema().describe());
        if (stage == "rock_tiles") return jsonText(rockpile::tilesSchema().describe());
        if (stage == "rock_pile") return jsonText(rockpile::pileSchema().describe());
        if (stage == "detail") return jsonText(detail::detailSchema().describe());
        if (stage == "block_tile") return jsonText(blocks::blocksSchema().describe());
        if (stage == "bake") return jsonText(fieldBakeSchema().describe());
        if (stage == "heightfield") return jsonText(heightfieldSchema().describe());
        if (stage == "mesh") return jsonText(meshSchema().describe());
        if (stage == "preview") return jsonText(previewSchema().describe());
        if (stage == "tile") return jsonText(blocks::tileSchema().describe());
        if (stage == "amplify") return jsonText(amplify::amplifySchema().describe());
        if (stage == "fractal_rock" || stage == "fractal_scatter") return jsonText(fractal::rockSchema().describe());
        if (stage == "arches") return archesSchemaText();
        if (stage == "asset") return jsonText(asset::assetSchema().describe());
        throw ValueError("schema: no stage '" + stage + "'");
    }, py::arg("stage"));
}
