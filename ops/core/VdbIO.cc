// SPDX-License-Identifier: Apache-2.0
#include "VdbIO.h"

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Error.h>

#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>

#include <tbb/task_arena.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdint>
#include <csignal>
#include <cstdlib>
#include <cstdio>
#include <atomic>
#include <chrono>
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <mutex>
#include <random>
#include <set>
#include <sstream>
#include <string_view>
#include <fcntl.h>
#include <poll.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

// Defined only in a sanitizer runtime (a weak reference stays null in a normal build).
extern "C" void __sanitizer_set_death_callback(void (*)(void)) __attribute__((weak));

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

// An output that is a symbolic link names the file it points to (followed, 40 links at most,
// a dangling link's target included): the new file replaces that target and the link stays.
std::string resolveTarget(const std::string& path)
{
    std::string p = path;
    for (int hops = 0; hops < 40; ++hops) {
        struct stat st;
        if (::lstat(p.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) return p;
        char buf[4096];
        const ssize_t n = ::readlink(p.c_str(), buf, sizeof buf - 1);
        if (n <= 0) return p;
        std::string to(buf, size_t(n));
        p = to[0] == '/' ? to : dirOf(p) + "/" + to;
    }
    fail<IoError>("cannot write '", path, "': too many levels of symbolic links");
}

// A character device or FIFO (/dev/null, /dev/stdout, a named pipe): written through, as a
// stream, never replaced by a renamed file (a FIFO without a reader waits for one, as any
// writer of it does; Ctrl-C still ends the tool).
bool isStreamTarget(const std::string& path)
{
    struct stat st;
    return ::stat(path.c_str(), &st) == 0 &&
           (S_ISCHR(st.st_mode) || S_ISFIFO(st.st_mode) || S_ISSOCK(st.st_mode));
}

void checkWritableTarget(const std::string& given)
{
    if (given.empty()) fail<ValueError>("output path is empty");
    const std::string path = resolveTarget(given);
    if (isStreamTarget(path)) {
        if (::access(path.c_str(), W_OK) != 0) {
            fail<IoError>("cannot write '", given, "': ", std::strerror(errno));
        }
        return;
    }
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

// OpenVDB's header (io::Archive::writeHeader, file format >= 219): magic (8 bytes), format
// version (4), library major and minor (4 + 4), grid-offsets flag (1), then the archive's UUID
// as 36 characters, a random one per write.
constexpr size_t kUuidAt = 21, kUuidLength = 36;

bool looksLikeUuid(std::string_view s)
{
    if (s.size() != kUuidLength) return false;
    for (size_t i = 0; i < s.size(); ++i) {
        const bool dash = (i == 8 || i == 13 || i == 18 || i == 23);
        if (dash ? s[i] != '-' : !std::isxdigit(static_cast<unsigned char>(s[i]))) return false;
    }
    return true;
}

// 128 bits of a file's bytes but its UUID field, as an RFC 9562 version-8 (custom) UUID; ""
// when the bytes do not start with the header above. One pass, 8 bytes a step in two lanes
// (a multiply-xorshift mix per word; FNV-1a a byte a step took 40 ms on a 24 MB tile set).
// Stable across runs, machines and builds.
std::string contentTag(std::string_view bytes)
{
    if (bytes.size() < kUuidAt + kUuidLength || !looksLikeUuid(bytes.substr(kUuidAt, kUuidLength))) {
        return {};
    }
    auto mix = [](uint64_t h) {
        h ^= h >> 33; h *= 0xff51afd7ed558ccdull;
        h ^= h >> 33; h *= 0xc4ceb9fe1a85ec53ull;
        return h ^ (h >> 33);
    };
    uint64_t hi = mix(1 ^ bytes.size()), lo = mix(2 ^ bytes.size());
    auto eat = [&](std::string_view part) {
        size_t i = 0;
        for (; i + 8 <= part.size(); i += 8) {
            uint64_t w;
            std::memcpy(&w, part.data() + i, 8);
            hi = mix(hi ^ w) + 0x9e3779b97f4a7c15ull;
            lo = mix(lo ^ w ^ 0x94d049bb133111ebull);
        }
        uint64_t tail = 0;
        std::memcpy(&tail, part.data() + i, part.size() - i);
        tail ^= uint64_t(part.size() - i) << 56;
        hi = mix(hi ^ tail);
        lo = mix(lo ^ tail ^ 0x94d049bb133111ebull);
    };
    eat(bytes.substr(0, kUuidAt));
    eat(bytes.substr(kUuidAt + kUuidLength));
    hi = (hi & ~0xf000ull) | 0x8000ull;                        // version 8
    lo = (lo & 0x3fffffffffffffffull) | 0x8000000000000000ull; // variant 10
    char text[kUuidLength + 1];
    std::snprintf(text, sizeof text, "%08x-%04x-%04x-%04x-%012llx", unsigned(hi >> 32),
                  unsigned((hi >> 16) & 0xffff), unsigned(hi & 0xffff), unsigned(lo >> 48),
                  static_cast<unsigned long long>(lo & 0xffffffffffffull));
    return std::string(text, kUuidLength);
}

// The header's UUID made from the rest of the file: the same grids give the same bytes, so a
// file is reproducible as its grids are. A chunk that a scheduler ran twice at once (a worker
// taken for dead under load) then writes its file twice with the same bytes, where a random
// UUID let one run's record hold the CRC-32 of a file the other run renamed over it. Readers
// that use the UUID (OpenVDB's Archive::isIdentical, delayed-load caches) take two files with
// one UUID for the same file, which they are.
void contentUuid(std::string& bytes)
{
    const std::string tag = contentTag(bytes);
    if (!tag.empty()) bytes.replace(kUuidAt, kUuidLength, tag); // (else: left as written)
}

std::string serialise(const openvdb::GridCPtrVec& grids)
{
    std::ostringstream os(std::ios_base::binary);
    openvdb::io::Stream stream(os);
    stream.setCompression(openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK);
    stream.write(fileOrder(grids));
    std::string bytes = os.str();
    contentUuid(bytes);
    return bytes;
}

} // namespace

void requireWritable(const std::string& path)
{
    if (path != "-") checkWritableTarget(path);
}

namespace {

// Temporary files that exist and are not renamed yet, for a signal handler to unlink: a slot
// is filled before the file is created and emptied after it is renamed or removed.
constexpr int kPendingSlots = 32;
char gPendingTemp[kPendingSlots][4096];
std::mutex gPendingMutex;
std::atomic<bool (*)()> gCommitCheck{nullptr};

class PendingTemp
{
public:
    explicit PendingTemp(const std::string& tmp)
    {
        std::lock_guard<std::mutex> lock(gPendingMutex);
        for (int i = 0; i < kPendingSlots && tmp.size() < sizeof gPendingTemp[0]; ++i) {
            if (gPendingTemp[i][0] == '\0') {
                std::memcpy(gPendingTemp[i] + 1, tmp.c_str() + 1, tmp.size());
                std::atomic_signal_fence(std::memory_order_seq_cst);
                gPendingTemp[i][0] = tmp[0]; // the slot counts from its first byte on
                mSlot = i;
                return;
            }
        }
    }
    ~PendingTemp()
    {
        std::lock_guard<std::mutex> lock(gPendingMutex);
        if (mSlot >= 0) gPendingTemp[mSlot][0] = '\0';
    }
    PendingTemp(const PendingTemp&) = delete;
    PendingTemp& operator=(const PendingTemp&) = delete;

private:
    int mSlot = -1;
};

// The open OutputBatch's outputs: (given name, target, temporary) written and not renamed,
// and the bytes for stdout.
struct PendingOutputs
{
    struct File
    {
        std::string given, path, tmp;
        std::unique_ptr<PendingTemp> pending;
    };
    std::vector<File> files;
    std::vector<std::pair<std::string, std::string>> streams; // devices, FIFOs: (given, path)
    std::vector<std::string> streamBytes;                     // what each of them gets
    std::string stdoutBytes;
    bool hasStdout = false;
};
PendingOutputs* gBatch = nullptr;

// Write through to a stream target (checkWritableTarget said which), all or an error.
void writeThrough(const std::string& given, const std::string& path, const std::string& bytes)
{
    if (auto check = gCommitCheck.load(); check && check()) throw Interrupted();
    const int fd = ::open(path.c_str(), O_WRONLY);
    if (fd < 0) fail<IoError>("cannot write '", given, "': ", std::strerror(errno));
    size_t done = 0;
    while (done < bytes.size()) {
        const ssize_t w = ::write(fd, bytes.data() + done, bytes.size() - done);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) {
            const int err = errno;
            ::close(fd);
            fail<IoError>("cannot write '", given, "': ", std::strerror(err));
        }
        done += size_t(w);
    }
    if (::close(fd) != 0) fail<IoError>("cannot write '", given, "': ", std::strerror(errno));
}

// Temporary file in the target's folder, then rename; the caller has checked the target. A
// symbolic link is followed (its target replaced), a device or FIFO written through.
void writeCheckedAtomic(const std::string& given, const std::string& bytes)
{
    const std::string path = resolveTarget(given);
    if (isStreamTarget(path)) {
        if (!gBatch) return writeThrough(given, path, bytes);
        gBatch->streams.emplace_back(given, path);
        gBatch->streamBytes.push_back(bytes);
        return;
    }
    const std::string tmp = tempNameFor(path);
    auto pending = std::make_unique<PendingTemp>(tmp);
    {
        std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
        if (!f) fail<IoError>("cannot write '", given, "': ", std::strerror(errno));
        f.write(bytes.data(), std::streamsize(bytes.size()));
        f.close();
        if (!f) {
            std::remove(tmp.c_str());
            fail<IoError>("cannot write '", given, "': write failed (disk full?)");
        }
    }
    if (gBatch) {
        gBatch->files.push_back({given, path, tmp, std::move(pending)});
        return;
    }
    if (auto check = gCommitCheck.load(); check && check()) {
        std::remove(tmp.c_str());
        throw Interrupted();
    }
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
        const int err = errno;
        std::remove(tmp.c_str());
        fail<IoError>("cannot write '", given, "': ", std::strerror(err));
    }
}

void writeOrKeepStdout(const std::string& bytes)
{
    if (!gBatch) return writeStdout(bytes);
    if (::isatty(STDOUT_FILENO)) writeStdout(bytes); // (refused: the message says why)
    if (gBatch->hasStdout) fail<ValueError>("two outputs of one run write to stdout");
    gBatch->hasStdout = true;
    gBatch->stdoutBytes = bytes;
}
} // namespace

void removePendingTemps()
{
    for (int i = 0; i < kPendingSlots; ++i) {
        if (gPendingTemp[i][0] != '\0') ::unlink(gPendingTemp[i]);
    }
}

OutputBatch::OutputBatch()
{
    if (gBatch) fail<std::logic_error>("an OutputBatch is already open");
    gBatch = new PendingOutputs;
}

OutputBatch::~OutputBatch()
{
    PendingOutputs* b = gBatch;
    gBatch = nullptr;
    for (auto& f : b->files) {
        if (!f.tmp.empty()) std::remove(f.tmp.c_str());
    }
    delete b;
}

void OutputBatch::commit()
{
    PendingOutputs* b = gBatch;
    if (!b) return;
    if (auto check = gCommitCheck.load(); check && check()) throw Interrupted(); // (~ removes)
    gBatch = nullptr; // the writes below go straight out
    try {
        // Streams first (a closed pipe fails before any file is replaced), then the renames.
        if (b->hasStdout) writeStdout(b->stdoutBytes);
        for (size_t i = 0; i < b->streams.size(); ++i) {
            writeThrough(b->streams[i].first, b->streams[i].second, b->streamBytes[i]);
        }
        for (size_t i = 0; i < b->files.size(); ++i) {
            auto& f = b->files[i];
            if (std::rename(f.tmp.c_str(), f.path.c_str()) != 0) {
                const int err = errno;
                fail<IoError>("cannot write '", f.given, "': ", std::strerror(err));
            }
            f.tmp.clear();
            f.pending.reset();
        }
    } catch (...) {
        gBatch = b; // ~OutputBatch removes what is left
        throw;
    }
    gBatch = b;
    b->files.clear();
}

void setCommitCheck(bool (*cancelled)()) { gCommitCheck.store(cancelled); }

void writeFileAtomic(const std::string& path, const std::string& bytes)
{
    if (path == "-") return writeOrKeepStdout(bytes);
    checkWritableTarget(path);
    writeCheckedAtomic(path, bytes);
}

namespace {

// What this process serialised itself (writeGrids): each file's size and content UUID (the
// header's, made from the rest of its bytes). Bytes of that size whose UUID is theirs and
// matches their content came from OpenVDB's own writer here, so reading them back needs no
// forked probe (readGrids): a rock pile made in Blender from the session's tile set read
// 24 MB through the probe, 1.1 of its 3.6 s. A file changed since (edited, truncated, another
// program's) has other bytes and is probed as any file.
std::mutex gWrittenMutex;
std::set<std::pair<size_t, std::string>> gWritten;

void rememberWritten(const std::string& bytes)
{
    if (bytes.size() < kUuidAt + kUuidLength) return;
    std::lock_guard<std::mutex> lock(gWrittenMutex);
    gWritten.emplace(bytes.size(), bytes.substr(kUuidAt, kUuidLength));
}

bool writtenHere(const std::string& bytes)
{
    if (bytes.size() < kUuidAt + kUuidLength) return false;
    {
        std::lock_guard<std::mutex> lock(gWrittenMutex);
        // (a tool that only reads, or bytes of a size and UUID never written, hash nothing)
        if (!gWritten.count({bytes.size(), bytes.substr(kUuidAt, kUuidLength)})) return false;
    }
    return contentTag(bytes) == std::string_view(bytes).substr(kUuidAt, kUuidLength);
}

std::atomic<size_t> gReadsChecked{0};

} // namespace

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
    rememberWritten(bytes);
    if (path == "-") return writeOrKeepStdout(bytes);
    writeCheckedAtomic(path, bytes);
}

namespace {

// A message from OpenVDB about a corrupt file can quote its bytes (a garbled grid name):
// printable ASCII only, so the one line stays one readable line.
std::string printable(const std::string& text)
{
    std::string out;
    for (unsigned char c : text) out += (c >= 0x20 && c < 0x7f) ? char(c) : '?';
    return out;
}

openvdb::GridPtrVecPtr parseVdb(const std::string& bytes, const std::string& name)
{
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
    } catch (const std::bad_alloc&) {
        throw;
    } catch (const std::exception& e) {
        fail<IoError>("cannot read '", name, "': truncated or corrupt VDB file (", printable(e.what()), ")");
    }
}

/// The memory a read of @a bytes may take before the file counts as corrupt: VDB data
/// expands by well under 64x from disk (blosc / zip of leaf buffers, active-value masks).
size_t readBudget(size_t bytes) { return std::max<size_t>(size_t(512) << 20, 64 * bytes); }

/// The CPU seconds a read of @a bytes may take before the file counts as corrupt: 10 s, plus
/// 1 s per 10 MB (reads run at ~100 MB/s; a garbled count can make OpenVDB's reader loop for
/// ever, which fuzz_vdb found).
unsigned readSeconds(size_t bytes) { return unsigned(10 + bytes / (10u << 20)); }

std::atomic<bool (*)()> gReadInterrupt{nullptr};

size_t addressSpace()
{
    std::ifstream f("/proc/self/statm");
    size_t pages = 0;
    f >> pages;
    return pages * size_t(::sysconf(_SC_PAGESIZE));
}

// OpenVDB's reader trusts the sizes and offsets in a file: one flipped byte can make it read
// past its buffers (SIGSEGV) or allocate gigabytes from a garbled size. So the bytes are
// parsed first in a child process, under a cap on its address space; only when that parse
// succeeds does this process parse them (the same bytes, the same result). The child only
// parses and reports through a pipe: one byte once it is ready to parse, then on success
// nothing, else the one-line message.

/// How one forked child ended. NotReady: it never became ready to parse (see probeVdb).
enum class Probe { Done, NotReady };

Probe probeOnce(const std::string& bytes, const std::string& name, std::chrono::milliseconds readyWithin)
{
    int pipeFd[2];
    if (::pipe(pipeFd) != 0) return Probe::Done; // no probe possible: read in-process, as before
    const size_t cap = addressSpace() + readBudget(bytes.size());
    const rlim_t seconds = readSeconds(bytes.size());
    const pid_t parent = ::getpid();
    std::fflush(nullptr);
    const pid_t pid = ::fork();
    if (pid < 0) {
        ::close(pipeFd[0]);
        ::close(pipeFd[1]);
        return Probe::Done;
    }
    if (pid == 0) {
        ::close(pipeFd[0]);
        // A crash here is the answer, not a finding: the parent's crash handlers (a
        // sanitizer's or libFuzzer's, which would report and write an artifact) are dropped.
        for (const int sig : {SIGSEGV, SIGBUS, SIGILL, SIGFPE, SIGABRT}) std::signal(sig, SIG_DFL);
        if (__sanitizer_set_death_callback) __sanitizer_set_death_callback(nullptr);
        // Quiet: glibc's heap checks print to stderr when a corrupt file trips them, and
        // OpenVDB's log warns on stdout (a pipeline's data) about a garbled version number.
        const int null = ::open("/dev/null", O_WRONLY);
        if (null >= 0) {
            ::dup2(null, STDERR_FILENO);
            ::dup2(null, STDOUT_FILENO);
        }
        // Dies with this process (a tool's watchdog exits at once on Ctrl-C), and after
        // readSeconds of CPU (SIGXCPU; SIGKILL a second later).
        ::prctl(PR_SET_PDEATHSIG, SIGKILL);
        if (::getppid() != parent) ::_exit(4);
        struct rlimit lim{cap, cap};
        ::setrlimit(RLIMIT_AS, &lim);
        struct rlimit cpu{seconds, seconds + 1};
        ::setrlimit(RLIMIT_CPU, &cpu);
        int code = 0;
        std::string message;
        try {
            // TBB after fork: this child has only the forking thread, but TBB's state says the
            // parent's workers exist, and a parallel loop here (OpenVDB frees a tree with
            // one, also a partly read one when the file is corrupt) waited for them for ever.
            // A fresh one-slot arena asks for no worker; the grids parsed are never freed
            // either (_exit below). Making the arena takes TBB's global lock, which a worker
            // of the parent may have held at the fork: then it waits for ever, before the
            // ready byte (the parent forks again).
            tbb::task_arena alone(1);
            alone.initialize();
            const char ready = 'R';
            if (::write(pipeFd[1], &ready, 1) != 1) ::_exit(4);
            alone.execute([&] { new openvdb::GridPtrVecPtr(parseVdb(bytes, name)); });
        } catch (const std::bad_alloc&) {
            code = 3;
        } catch (const std::exception& e) {
            code = 1;
            message = e.what();
        } catch (...) {
            code = 1;
            message = "cannot read '" + name + "': corrupt VDB file";
        }
        if (!message.empty()) {
            const ssize_t w = ::write(pipeFd[1], message.data(), message.size());
            (void)w;
        }
        ::_exit(code);
    }
    ::close(pipeFd[1]);
    std::string message;
    char buf[512];
    // Wait for the child's answer, asking the host every 50 ms whether to give up (Python's
    // Ctrl-C; the tools' watchdog needs no asking). The CPU limit ends a child that loops; one
    // that waits for ever (a lock that another thread held when this process forked) is ended
    // by a wall-clock limit of three times its CPU budget, plus 10 s for a loaded machine.
    const auto start = std::chrono::steady_clock::now();
    const auto deadline = start + std::chrono::seconds(3 * seconds + 10);
    bool ready = false, interrupted = false, stalled = false, notReady = false;
    for (;;) {
        pollfd pfd{pipeFd[0], POLLIN, 0};
        const int got = ::poll(&pfd, 1, 50);
        if (got == 0 || (got < 0 && errno == EINTR)) {
            bool (*check)() = gReadInterrupt.load();
            const auto now = std::chrono::steady_clock::now();
            interrupted = check && check();
            stalled = now > deadline;
            notReady = !ready && now > start + readyWithin;
            if (interrupted || stalled || notReady) {
                ::kill(pid, SIGKILL);
                break;
            }
            continue;
        }
        if (got < 0) break;
        const ssize_t r = ::read(pipeFd[0], buf, sizeof buf);
        if (r > 0) {
            const size_t skip = ready ? 0 : 1;  // the ready byte
            ready = true;
            message.append(buf + skip, size_t(r) - skip);
        } else if (r == 0 || errno != EINTR) {
            break;
        }
    }
    ::close(pipeFd[0]);
    int status = 0;
    struct rusage usage{};
    while (::wait4(pid, &status, 0, &usage) < 0 && errno == EINTR) {}
    if (interrupted) throw Interrupted();
    if (notReady) return Probe::NotReady;
    const double cpu = double(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
                       1e-6 * double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return Probe::Done;
    if (WIFEXITED(status) && WEXITSTATUS(status) == 1 && !message.empty()) throw IoError(message);
    if (WIFEXITED(status) && WEXITSTATUS(status) == 3) {
        fail<IoError>("cannot read '", name, "': corrupt VDB file (reading its ", bytes.size(),
                      " bytes asked for more than ", readBudget(bytes.size()) >> 20,
                      " MB: a size in it is out of range)");
    }
    if (stalled && cpu < double(seconds)) {
        fail<IoError>("cannot read '", name, "': OpenVDB's reader stopped making progress on its ",
                      bytes.size(), " bytes (no answer after ", 3 * seconds + 10, " s)");
    }
    if (WIFSIGNALED(status) && (WTERMSIG(status) == SIGXCPU ||
                                (WTERMSIG(status) == SIGKILL && cpu >= double(seconds)))) {
        fail<IoError>("cannot read '", name, "': corrupt VDB file (OpenVDB's reader was still reading its ",
                      bytes.size(), " bytes after ", seconds, " s: a count in it is out of range)");
    }
    if (WIFSIGNALED(status)) {
        fail<IoError>("cannot read '", name, "': corrupt VDB file (OpenVDB's reader crashed on it: ",
                      printable(::strsignal(WTERMSIG(status))), ")");
    }
    fail<IoError>("cannot read '", name, "': corrupt VDB file");
}

/// Probes @a bytes in a forked child (probeOnce). A fork copies TBB's global lock as it was at
/// that instant: held by a worker of this process (about one fork in 500 while workers run,
/// measured), the child can never make its arena. Such a child never becomes ready; it is
/// killed and the bytes probed in a new fork, waiting longer for each (a loaded machine can
/// be slow to run a child at all): 0.5 s, 1 s, 2 s, ... up to 16 s.
void probeVdb(const std::string& bytes, const std::string& name)
{
    if (std::getenv("ROCKVDB_TRUST_VDB")) return; // (for measuring the probe's cost only)
    for (int ms = 500; ms <= 16000; ms *= 2) {
        if (probeOnce(bytes, name, std::chrono::milliseconds(ms)) == Probe::Done) return;
    }
    fail<IoError>("cannot read '", name, "': the process that checks it never started (forked 6 times)");
}

} // namespace

void setReadInterrupt(bool (*check)()) { gReadInterrupt.store(check); }

size_t readsChecked() { return gReadsChecked.load(); }

openvdb::GridPtrVecPtr readGrids(const std::string& path)
{
    initialize();
    std::string bytes;
    const std::string name = path == "-" ? std::string("<stdin>") : path;
    if (path == "-") {
        if (::isatty(STDIN_FILENO)) {
            fail<ValueError>("expected a .vdb on stdin, but stdin is a terminal");
        }
        // A stream has no size to check first: read it in blocks, up to half the RAM (an
        // endless one, /dev/zero say, would otherwise take it all).
        const size_t limit = size_t(0.5 * physicalMemoryBytes());
        char block[1 << 16];
        while (std::cin.read(block, sizeof block) || std::cin.gcount() > 0) {
            bytes.append(block, size_t(std::cin.gcount()));
            if (bytes.size() >= 8 && std::memcmp(bytes.data(), " BDV\0\0\0\0", 8) != 0) {
                fail<IoError>("cannot read '<stdin>': not a VDB file");
            }
            if (bytes.size() > limit) {
                fail<IoError>("cannot read '<stdin>': more than ", limit >> 20, " MB (half the RAM) on stdin");
            }
        }
    } else {
        struct stat st;
        if (::stat(path.c_str(), &st) != 0) {
            fail<IoError>("cannot read '", path, "': no such file");
        }
        if (S_ISDIR(st.st_mode)) fail<IoError>("cannot read '", path, "': it is a folder");
        if (!S_ISREG(st.st_mode)) {
            fail<IoError>("cannot read '", path, "': not a regular file (a device, pipe or socket; give '-' to read a "
                          "stream from stdin)");
        }
        std::ifstream f(path, std::ios::binary);
        if (!f) fail<IoError>("cannot read '", path, "': ", std::strerror(errno));
        bytes.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
    }
    // "VDB " magic as a little-endian int64 at offset 0.
    if (bytes.size() < 8 || std::memcmp(bytes.data(), " BDV\0\0\0\0", 8) != 0) {
        fail<IoError>("cannot read '", name, "': not a VDB file");
    }
    // The format version follows the magic. OpenVDB reads a newer one anyway, after a warning
    // that its log prints on stdout (a pipeline's data): refuse it here, in one line.
    uint32_t format = 0;
    if (bytes.size() >= 12) std::memcpy(&format, bytes.data() + 8, sizeof format);
    if (format > openvdb::OPENVDB_FILE_VERSION) {
        fail<IoError>("cannot read '", name, "': VDB file format version ", format, " is newer than ",
                      "this OpenVDB reads (", openvdb::OPENVDB_FILE_VERSION, " or earlier)");
    }
    if (!writtenHere(bytes)) {
        probeVdb(bytes, name);
        ++gReadsChecked;
    }
    try {
        return parseVdb(bytes, name);
    } catch (const std::bad_alloc&) {
        fail<IoError>("cannot read '", name, "': out of memory reading ", bytes.size(), " bytes");
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
        if (levelSets == 1) {
            // The grid itself, not a look-up by its name: a nameless level set would recurse
            // here for ever (fuzz_vdb found the stack overflow), and a name two grids share
            // could pick the other one.
            requireLevelSet(*only, "grid '" + only->getName() + "' in '" + source + "'");
            return openvdb::gridPtrCast<openvdb::FloatGrid>(only);
        }
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
