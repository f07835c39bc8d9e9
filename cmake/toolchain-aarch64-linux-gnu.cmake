# Cross-compiling aerovo for aarch64 Linux (Raspberry Pi 5, Jetson, RB5, ...) on an x86-64 Debian 12
# host with Debian's cross compiler (g++-aarch64-linux-gnu) and arm64 libraries installed through
# multiarch (scripts/install-deps-aarch64.sh). Tests run under qemu-user (CMake's cross-compiling
# emulator: ctest and gtest_discover_tests start every test binary through it). Use:
#   cmake -S . -B build-aarch64 -DCMAKE_TOOLCHAIN_FILE=cmake/toolchain-aarch64-linux-gnu.cmake \
#     -DAEROVO_CORE_ONLY=ON     (scripts/test-aarch64.sh)
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)

set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)

# The cross toolchain's own sysroot (libc, libstdc++, libgomp: the *-arm64-cross packages) and
# the multiarch arm64 packages (/usr/lib/aarch64-linux-gnu, headers in /usr/include, which also
# holds the architecture-independent header-only libraries: Eigen, nlohmann-json).
set(CMAKE_FIND_ROOT_PATH /usr/aarch64-linux-gnu /)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)   # build tools (pkg-config, ...) are the host's
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

# pkg-config (GeographicLib, Highway) must read the arm64 .pc files, not the host's.
set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_PATH} "")

# qemu-user runs the aarch64 test binaries; -L: where the arm64 dynamic loader and libc live.
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64;-L;/usr/aarch64-linux-gnu)
