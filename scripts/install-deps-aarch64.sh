#!/usr/bin/env bash
# Installs what the aarch64 cross build (scripts/test-aarch64.sh) needs on an x86-64 Debian 12
# host: the cross compiler, qemu-user, and the arm64 libraries of the core modules through
# multiarch (dpkg --add-architecture arm64). Eigen and nlohmann-json are header-only and come with
# the host's -dev packages (scripts/install-deps.sh); OpenCV is not needed (AEROVO_CORE_ONLY).
# Idempotent and quiet: packages already present are left alone; apt runs only when one is missing.
set -euo pipefail
HOST_PKGS=(
  g++-aarch64-linux-gnu   # Debian's cross compiler (libc, libstdc++, libgomp as *-arm64-cross)
  qemu-user               # qemu-aarch64: runs the aarch64 tests (CMAKE_CROSSCOMPILING_EMULATOR)
  libeigen3-dev nlohmann-json3-dev  # header-only, architecture-independent
)
ARM_PKGS=(
  # geo: the arm64 GeographicLib library only. Its -dev package is not Multi-Arch: same, so
  # installing libgeographiclib-dev:arm64 would REMOVE the host's libgeographiclib-dev; the
  # headers are architecture-independent (the host's), the top CMakeLists.txt links the .so.23.
  libgeographiclib23:arm64
  libfmt-dev:arm64             # camera, mavlink, odometry
  # mavlink: libcrypto's SHA-256 (message signing). Multi-Arch: same, so apt keeps the host's
  # libssl-dev, at the same version (it upgrades the host's when the arm64 one is newer).
  libssl-dev:arm64
  libhwy-dev:arm64             # Google Highway (the SIMD kernels: NEON/SVE at run time)
  libgtest-dev:arm64 libgmock-dev:arm64  # the unit tests
)
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
if ! dpkg --print-foreign-architectures | grep -qx arm64; then
  $SUDO dpkg --add-architecture arm64
fi
missing=()
for p in "${HOST_PKGS[@]}" "${ARM_PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps-aarch64: all $((${#HOST_PKGS[@]} + ${#ARM_PKGS[@]})) packages already installed"
  exit 0
fi
echo "install-deps-aarch64: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
# Never let an arm64 package replace a host package (a -dev package that is not Multi-Arch: same
# would remove the amd64 one and break the x86 build): refuse when apt would remove anything.
if apt-get install -s --no-install-recommends "${missing[@]}" | grep -q '^Remv'; then
  echo "install-deps-aarch64: installing ${missing[*]} would remove packages:" >&2
  apt-get install -s --no-install-recommends "${missing[@]}" | grep '^Remv' >&2
  exit 1
fi
$SUDO apt-get install -y -qq --no-install-recommends -o Dpkg::Options::=--force-unsafe-io \
  "${missing[@]}" >/dev/null
echo "install-deps-aarch64: done"
