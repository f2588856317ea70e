#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# rockvdb set-up, build and run.
#   ./rockvdb.sh demo [--quality preview|draft|default|high]
#                       install the Debian packages the tools need, build the tools (Release,
#                       -j2), bake the demo scene to out/demo.vdb and render out/demo.png
#                       (ROCKVDB_QUALITY works too)
#   ./rockvdb.sh test   install every package (the tests' clients too: Blender, Xvfb, clang,
#                       Dask), build everything, run every test (C++, Python, CLI, real clients)
#                       via CTest, then the sanitizer and fuzz jobs (.ci/sanitize: ASan + UBSan
#                       build of the C++ tests, libFuzzer targets for 30 s each, TSan build of
#                       the baker and stage tests)
#   ./rockvdb.sh build  test's set-up and build only
set -euo pipefail
cd "$(dirname "$0")"
MODE="${1:-demo}"

# What the tools need to build (the demo runs nothing else) ...
DEMO_PACKAGES=(
    cmake g++ make ccache pkg-config python3
    libopenvdb-dev libboost-iostreams-dev libtbb-dev libopenexr-dev libblosc-dev libglm-dev
    libcgal-dev libgmp-dev libmpfr-dev libpng-dev libcli11-dev nlohmann-json3-dev
    libjemalloc-dev libmeshoptimizer-dev libtinygltf-dev
)
# ... what the Python module and the tests need to build ...
BUILD_PACKAGES=(pybind11-dev libboost-python-dev python3-dev libgtest-dev)
# ... and what the tests run: the real clients (pyopenvdb, vdb_print / vdb_render / vdb_tool,
# Blender under Xvfb), the sanitizer builds' clang, Dask.
TEST_PACKAGES=(
    python3-openvdb python3-numpy python3-pytest python3-pil
    libopenvdb-tools blender xvfb
    clang libclang-rt-14-dev dpkg-dev
    python3-distributed python3-dask
)

missing() { # packages... -> those not installed
    for p in "$@"; do
        dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || echo "$p"
    done
}
APT_UPDATED=0
install_packages() { # [--log FILE] packages...
    local log=/dev/stderr
    if [ "$1" = "--log" ]; then log="$2"; shift 2; fi
    local need
    mapfile -t need < <(missing "$@")
    ((${#need[@]})) || return 0
    local sudo=""
    if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
    echo "rockvdb: installing ${need[*]}" >&2
    if [ "$APT_UPDATED" = 0 ]; then $sudo apt-get update -qq; APT_UPDATED=1; fi
    # force-unsafe-io: dpkg skips its fsync per unpacked file (a fresh machine's hundreds of
    # packages, Blender's among them); an interrupted install is redone by the next run.
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq \
        -o Dpkg::Options::=--force-unsafe-io "${need[@]}" >>"$log" 2>&1 || {
        [ "$log" = /dev/stderr ] || tail -20 "$log" >&2
        echo "rockvdb: installing ${need[*]} failed" >&2
        return 1
    }
}
configure() {
    cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DPython3_EXECUTABLE=/usr/bin/python3 >/dev/null
}

case "$MODE" in
    demo)
        install_packages "${DEMO_PACKAGES[@]}"
        PACKAGES_SECONDS=$SECONDS
        configure
        cmake --build build -j2 --target rockvdb_tools
        ;;
    test|build)
        install_packages "${DEMO_PACKAGES[@]}" "${BUILD_PACKAGES[@]}"
        PACKAGES_SECONDS=$SECONDS
        configure
        # The build is compute, the test packages' install mostly download and unpacking: the
        # two run side by side, the install's log in build/test-packages.log. The build runs
        # in its own process group, so a failed install (or Ctrl-C) stops all of it.
        setsid -w cmake --build build -j2 &
        BUILD_PID=$!
        trap 'kill -- -"$BUILD_PID" 2>/dev/null || true' EXIT
        T0=$SECONDS
        install_packages --log build/test-packages.log "${TEST_PACKAGES[@]}"
        TEST_PACKAGES_SECONDS=$((SECONDS - T0))
        wait "$BUILD_PID"
        trap - EXIT
        ;;
    *) echo "usage: $0 [demo|test|build]" >&2; exit 2 ;;
esac
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
             "build $((SETUP_SECONDS - PACKAGES_SECONDS)) s (the test packages' install" \
             "${TEST_PACKAGES_SECONDS} s of it, alongside)," \
             "tests ${TESTS_SECONDS} s (${TESTS_COUNT} tests)," \
             "sanitizers and fuzzing $((SECONDS - SETUP_SECONDS - TESTS_SECONDS)) s," \
             "total ${SECONDS} s" >&2
        ;;
    build) ;;
esac
