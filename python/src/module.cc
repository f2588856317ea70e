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

namespace {

/// A stage's table by its Python name.
const SchemaBase& schemaOf(const std::string& stage)
{
    if (stage == "csg") return csgSchema();
    if (stage == "rock_tiles") return rockpile::tilesSchema();
    if (stage == "rock_pile") return rockpile::pileSchema();
    if (stage == "detail") return detail::detailSchema();
    if (stage == "block_tile") return blocks::blocksSchema();
    if (stage == "bake") return fieldBakeSchema();
    if (stage == "heightfield") return heightfieldSchema();
    if (stage == "mesh") return meshSchema();
    if (stage == "preview") return previewSchema();
    if (stage == "tile") return blocks::tileSchema();
    if (stage == "amplify") return amplify::amplifySchema();
    if (stage == "fractal_rock" || stage == "fractal_scatter") return fractal::rockSchema();
    if (stage == "arches") return archesSchemaBase();
    if (stage == "asset") return asset::assetSchema();
    throw ValueError("schema: no stage '" + stage + "'");
}

} // namespace

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
    m.def("schema", [](const std::string& stage) { return jsonText(schemaOf(stage).describe()); },
          py::arg("stage"));
    // What a call's parameters stand for, every derived default filled (the Blender add-on
    // shows these beside its Auto boxes).
    m.def("derive", [](const std::string& stage, const std::string& params) {
        return jsonText(schemaOf(stage).derivedValues(parseParams(params, stage.c_str())));
    }, py::arg("stage"), py::arg("params"));
    // The preview quality's rule (core/Schema.h), for front-ends.
    m.def("preview_voxel_size", &previewVoxelSize, py::arg("final_voxel"), py::arg("extent"),
          "Preview quality: the voxel size for a result of largest extent @a extent (m)");
    m.attr("PREVIEW_ADAPTIVITY") = kPreviewAdaptivity;
    m.attr("PREVIEW_VOXELS_ACROSS") = kPreviewVoxelsAcross;
    m.attr("PREVIEW_COARSEST") = kPreviewCoarsest;
}
