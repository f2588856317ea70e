#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# rockvdb set-up, build and run.
#   ./rockvdb.sh demo [--quality preview|draft|default|high]
#                       install missing Debian packages, build (Release, -j2), bake the demo
#                       scene to out/demo.vdb and render out/demo.png (ROCKVDB_QUALITY works too)
#   ./rockvdb.sh test   same set-up, then run every test (C++, Python, CLI, real clients) via CTest,
#                       then the sanitizer and fuzz jobs (.ci/sanitize: ASan + UBSan build of
#                       the C++ tests, libFuzzer targets for 30 s each, TSan build of the
#                       baker and stage tests)
#   ./rockvdb.sh build  set-up and build only
set -euo pipefail
cd "$(dirname "$0")"
MODE="${1:-demo}"

PACKAGES=(
    cmake g++ make ccache pkg-config
    libopenvdb-dev libboost-iostreams-dev libtbb-dev libopenexr-dev libblosc-dev libglm-dev
    libcgal-dev libgmp-dev libmpfr-dev libpng-dev libcli11-dev nlohmann-json3-dev
    pybind11-dev libboost-python-dev python3-dev python3-openvdb python3-numpy python3-pytest python3-pil
    libgtest-dev libbenchmark-dev libjemalloc-dev libmeshoptimizer-dev libtinygltf-dev
    libopenvdb-tools blender xvfb
    clang libclang-rt-14-dev dpkg-dev
    python3-distributed python3-dask
)

missing=()
for p in "${PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
    SUDO=""
    if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
    echo "rockvdb: installing ${missing[*]}" >&2
    $SUDO apt-get update -qq
    # force-unsafe-io: dpkg skips its fsync per unpacked file (a fresh machine's hundreds of
    # packages, Blender's among them); an interrupted install is redone by the next run.
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq \
        -o Dpkg::Options::=--force-unsafe-io "${missing[@]}" >&2
fi

PACKAGES_SECONDS=$SECONDS
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DPython3_EXECUTABLE=/usr/bin/python3 >/dev/null
cmake --build build -j2
SETUP_SECONDS=$SECONDS

case "$MODE" in
    demo)
        mkdir -p out
        ./samples/01_demo.sh build out "${@:2}"
        echo "rockvdb: wrote out/demo.vdb and out/demo.png" >&2
        ;;
    test)
        (cd build && ctest --output-on-failure -j2 --timeout 1500)
        TESTS_SECONDS=$((SECONDS - SETUP_SECONDS))
        TESTS_COUNT=$(cd build && ctest -N | sed -n 's/^Total Tests: //p')
        ./.ci/sanitize
        # Where CI's time goes (its limit is 90 minutes, the goal 35), read at the end; the
        # sanitizer line above it has that job's phases and test counts.
        echo "rockvdb: test: packages ${PACKAGES_SECONDS} s," \
             "build $((SETUP_SECONDS - PACKAGES_SECONDS)) s," \
             "tests ${TESTS_SECONDS} s (${TESTS_COUNT} tests)," \
             "sanitizers and fuzzing $((SECONDS - SETUP_SECONDS - TESTS_SECONDS)) s," \
             "total ${SECONDS} s" >&2
        ;;
    build) ;;
    *) echo "usage: $0 [demo|test|build]" >&2; exit 2 ;;
esac
