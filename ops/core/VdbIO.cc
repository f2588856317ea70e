#include "VdbIO.h"

#include <rockvdb/core/Error.h>

#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <atomic>
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <mutex>
#include <random>
#include <sstream>
#include <sys/stat.h>
#include <unistd.h>

#ifndef ROCKVDB_VERSION
#define ROCKVDB_VERSION "0.0.0"
#endif

namespace rockvdb {

const char* version() { return ROCKVDB_VERSION; }

void initialize()
{
    static std::once_flag once;
    std::call_once(once, [] { openvdb::initialize(); });
}

void stampProvenance(openvdb::GridBase& grid, const std::string& generator,
                     const std::string& paramsJson)
{
    grid.insertMeta("rockvdb:version", openvdb::StringMetadata(version()));
    grid.insertMeta("rockvdb:generator", openvdb::StringMetadata(generator));
    grid.insertMeta("rockvdb:params", openvdb::StringMetadata(paramsJson));
}

std::optional<Provenance> provenance(const openvdb::GridBase& grid)
{
    auto get = [&](const char* key) -> std::optional<std::string> {
        auto m = grid.getMetadata<openvdb::StringMetadata>(key);
        if (!m) return std::nullopt;
        return m->value();
    };
    auto v = get("rockvdb:version"), g = get("rockvdb:generator"), p = get("rockvdb:params");
    if (!v || !g || !p) return std::nullopt;
    return Provenance{*v, *g, *p};
}

namespace {

std::string dirOf(const std::string& path)
{
    const auto slash = path.find_last_of('/');
    if (slash == std::string::npos) return ".";
    if (slash == 0) return "/";
    return path.substr(0, slash);
}

std::string baseOf(const std::string& path)
{
    const auto slash = path.find_last_of('/');
    return slash == std::string::npos ? path : path.substr(slash + 1);
}

void checkWritableTarget(const std::string& path)
{
    if (path.empty()) fail<ValueError>("output path is empty");
    const std::string dir = dirOf(path);
    struct stat st;
    if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
        fail<IoError>("cannot write '", path, "': folder '", dir, "' does not exist");
    }
    if (::access(dir.c_str(), W_OK) != 0) {
        fail<IoError>("cannot write '", path, "': folder '", dir, "' is not writable");
    }
    if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
        fail<IoError>("cannot write '", path, "': it is a folder");
    }
}

std::string tempNameFor(const std::string& path)
{
    std::random_device rd;
    std::ostringstream os;
    os << dirOf(path) << "/." << baseOf(path) << ".tmp-" << ::getpid() << "-" << std::hex
       << rd();
    return os.str();
}

void writeStdout(const std::string& bytes)
{
    if (::isatty(STDOUT_FILENO)) {
        fail<ValueError>("refusing to write binary data to a terminal; redirect stdout or "
                         "give -o FILE");
    }
    std::cout.write(bytes.data(), std::streamsize(bytes.size()));
    std::cout.flush();
    if (!std::cout) fail<IoError>("cannot write to stdout");
}

/// Grids in file order: attribute grids first, level sets after them, 'surface' last. Tools
/// that act on the most recently read grid (vdb_tool's -ls2mesh, -ls2fog with their default
/// age 0) then find the level set; readers by name are unaffected.
openvdb::GridCPtrVec fileOrder(const openvdb::GridCPtrVec& grids)
{
    auto rank = [](const openvdb::GridBase::ConstPtr& g) {
        if (!g || g->getGridClass() != openvdb::GRID_LEVEL_SET) return 0;
        return g->getName() == "surface" ? 2 : 1;
    };
    openvdb::GridCPtrVec out(grids);
    std::stable_sort(out.begin(), out.end(),
                     [&](const auto& a, const auto& b) { return rank(a) < rank(b); });
    return out;
}

std::string serialise(const openvdb::GridCPtrVec& grids)
{
    std::ostringstream os(std::ios_base::binary);
    openvdb::io::Stream stream(os);
    stream.setCompression(openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK);
    stream.write(fileOrder(grids));
    return os.str();
}

} // namespace

void requireWritable(const std::string& path)
{
    if (path != "-") checkWritableTarget(path);
}

namespace {

char gPendingTemp[4096] = "";
std::atomic<bool (*)()> gCommitCheck{nullptr};

// The temporary file named in gPendingTemp while it exists (a signal handler may read it).
class PendingTemp
{
public:
    explicit PendingTemp(const std::string& tmp)
    {
        if (tmp.size() < sizeof gPendingTemp) std::memcpy(gPendingTemp, tmp.c_str(), tmp.size() + 1);
    }
    ~PendingTemp() { gPendingTemp[0] = '\0'; }
};

// Temporary file in the target's folder, then rename; the caller has checked the target.
void writeCheckedAtomic(const std::string& path, const std::string& bytes)
{
    const std::string tmp = tempNameFor(path);
    PendingTemp pending(tmp);
    {
        std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
        if (!f) fail<IoError>("cannot write '", path, "': ", std::strerror(errno));
        f.write(bytes.data(), std::streamsize(bytes.size()));
        f.close();
        if (!f) {
            std::remove(tmp.c_str());
            fail<IoError>("cannot write '", path, "': write failed (disk full?)");
        }
    }
    if (auto check = gCommitCheck.load(); check && check()) {
        std::remove(tmp.c_str());
        throw Interrupted();
    }
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
        const int err = errno;
        std::remove(tmp.c_str());
        fail<IoError>("cannot write '", path, "': ", std::strerror(err));
    }
}
} // namespace

const char* pendingTempFile() { return gPendingTemp; }

void setCommitCheck(bool (*cancelled)()) { gCommitCheck.store(cancelled); }

void writeFileAtomic(const std::string& path, const std::string& bytes)
{
    if (path == "-") return writeStdout(bytes);
    checkWritableTarget(path);
    writeCheckedAtomic(path, bytes);
}

void writeGrids(const std::string& path, const openvdb::GridCPtrVec& grids)
{
    initialize();
    if (path != "-") checkWritableTarget(path);
    std::string bytes;
    try {
        bytes = serialise(grids);
    } catch (const openvdb::Exception& e) {
        fail<IoError>("cannot write '", path, "': ", e.what());
    }
    if (path == "-") return writeStdout(bytes);
    writeCheckedAtomic(path, bytes);
}

openvdb::GridPtrVecPtr readGrids(const std::string& path)
{
    initialize();
    std::string bytes;
    const std::string name = path == "-" ? std::string("<stdin>") : path;
    if (path == "-") {
        if (::isatty(STDIN_FILENO)) {
            fail<ValueError>("expected a .vdb on stdin, but stdin is a terminal");
        }
        bytes.assign(std::istreambuf_iterator<char>(std::cin), std::istreambuf_iterator<char>());
    } else {
        struct stat st;
        if (::stat(path.c_str(), &st) != 0) {
            fail<IoError>("cannot read '", path, "': no such file");
        }
        if (S_ISDIR(st.st_mode)) fail<IoError>("cannot read '", path, "': it is a folder");
        std::ifstream f(path, std::ios::binary);
        if (!f) fail<IoError>("cannot read '", path, "': ", std::strerror(errno));
        bytes.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
    }
    // "VDB " magic as a little-endian int64 at offset 0.
    if (bytes.size() < 8 || std::memcmp(bytes.data(), " BDV\0\0\0\0", 8) != 0) {
        fail<IoError>("cannot read '", name, "': not a VDB file");
    }
    try {
        std::istringstream is(bytes, std::ios_base::binary);
        openvdb::io::Stream stream(is, /*delayLoad=*/false);
        openvdb::GridPtrVecPtr grids = stream.getGrids();
        if (!grids) fail<IoError>("cannot read '", name, "': no grids");
        // A truncated stream can leave the last grid short: check the bytes were consumed
        // and each tree is internally consistent.
        if (is.fail()) fail<IoError>("cannot read '", name, "': truncated VDB file");
        return grids;
    } catch (const IoError&) {
        throw;
    } catch (const std::exception& e) {
        fail<IoError>("cannot read '", name, "': truncated or corrupt VDB file (", e.what(), ")");
    }
}

void requireLevelSet(const openvdb::GridBase& grid, const std::string& what)
{
    if (!grid.isType<openvdb::FloatGrid>()) {
        fail<ValueError>(what, " is a ", grid.type(), ", not a float level set");
    }
    if (grid.getGridClass() != openvdb::GRID_LEVEL_SET) {
        const auto cls = grid.getGridClass();
        fail<ValueError>(what, " is a ",
                         cls == openvdb::GRID_FOG_VOLUME ? "fog volume" : "grid of class '" +
                             openvdb::GridBase::gridClassToString(cls) + "'",
                         ", not a level set");
    }
    if (!grid.hasUniformVoxels()) fail<ValueError>(what, " has non-uniform voxels");
}

openvdb::FloatGrid::Ptr findLevelSet(const openvdb::GridPtrVec& grids, const std::string& name,
                                     const std::string& source)
{
    if (name.empty()) {
        // The default: 'surface', else the only level set of the file.
        openvdb::GridBase::Ptr only;
        int levelSets = 0;
        for (const auto& g : grids) {
            if (!g) continue;
            if (g->getName() == "surface") return findLevelSet(grids, "surface", source);
            if (g->isType<openvdb::FloatGrid>() && g->getGridClass() == openvdb::GRID_LEVEL_SET) {
                only = g;
                ++levelSets;
            }
        }
        if (levelSets == 1) return findLevelSet(grids, only->getName(), source);
        std::string names;
        for (const auto& g : grids) {
            if (g) names += (names.empty() ? "" : ", ") + ("'" + g->getName() + "'");
        }
        fail<ValueError>("'", source, "' has no grid 'surface' and ",
                         levelSets ? "several level sets" : "no float level set", " (it has ",
                         names.empty() ? std::string("no grids") : names,
                         "): name the grid to use");
    }
    std::string names;
    for (const auto& g : grids) {
        if (!g) continue;
        if (g->getName() == name) {
            requireLevelSet(*g, "grid '" + name + "' in '" + source + "'");
            return openvdb::gridPtrCast<openvdb::FloatGrid>(g);
        }
        names += (names.empty() ? "" : ", ") + ("'" + g->getName() + "'");
    }
    fail<ValueError>("no grid '", name, "' in '", source, "' (it has ",
                     names.empty() ? std::string("no grids") : names, ")");
}

openvdb::FloatGrid::Ptr readLevelSet(const std::string& path, const std::string& name)
{
    auto grids = readGrids(path);
    return findLevelSet(*grids, name, path == "-" ? "<stdin>" : path);
}

} // namespace rockvdb
