#!/usr/bin/env bash
# Installs every system dependency of aerovo from Debian 12's archive.
# Idempotent: packages already present are left alone; safe to run on every CI start.
set -euo pipefail
PKGS=(
  build-essential cmake ninja-build pkg-config git
  mold                   # linker of scripts/test.sh's builds (many test executables)
  libopencv-dev          # video/image I/O, colour, drawing, SIFT/ORB/AKAZE baselines
  libeigen3-dev          # geometry
  libgeographiclib-dev   # geodesy (LocalCartesian, WGS84)
  libexiv2-dev           # EXIF/XMP telemetry of photos
  libhwy-dev             # Google Highway: portable SIMD kernels with run-time dispatch
  libpugixml-dev         # GPX (XML) telemetry
  libavformat-dev libavcodec-dev libavutil-dev libswscale-dev  # the video decoder (frames/video_decoder.h)
  libgdal-dev gdal-bin   # GeoTIFF + KMZ of the geo-referenced mosaic (aerovo report); gdalinfo/ogrinfo in tests
  libyaml-dev            # YAML run configuration files (aerovo run --config x.yaml)
  libssl-dev             # libcrypto's SHA-256: MAVLink 2 message signing (aerovo run --mavlink-key)
  libcli11-dev nlohmann-json3-dev libspdlog-dev libfmt-dev
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  gnuplot-nox            # figures (SVG/PNG)
  chromium               # headless browser test of the HTML report (aerovo report)
  libjs-leaflet          # the report's offline map: Leaflet compiled into report/ (BSD-2-Clause)
  ffmpeg                 # encoders used by OpenCV's VideoWriter
  clang-format
  clang libclang-rt-14-dev  # libFuzzer + sanitizer runtimes for the fuzz targets (scripts/fuzz.sh)
  llvm                   # llvm-symbolizer: symbolised sanitizer and fuzzer stack traces
  pybind11-dev python3-dev python3-numpy  # the Python module (python/: import aerovo)
  python3-pytest         # its tests (ctest python_tests)
)
# node + npm: the MAVLink end-to-end tests (tests/mavlink) install node-mavlink from the npm
# registry, an independent MAVLink implementation, to check aerovo's packets. Debian 12's nodejs
# (18) and npm, unless a node and npm are already on PATH (e.g. from nodesource).
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  PKGS+=(nodejs npm)
fi
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PKGS[@]} packages already installed"
  exit 0
fi
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
# --force-unsafe-io: dpkg does not fsync each file of the ~360 packages as it unpacks them (a
# fresh CI machine installs them all; dpkg(1), --force-unsafe-io). On a CI machine (CI set),
# man-db's trigger does not rebuild the manual page index at the end (debconf man-db/auto-update).
if [ -n "${CI:-}" ]; then
  echo "man-db man-db/auto-update boolean false" | $SUDO debconf-set-selections 2>/dev/null || true
fi
$SUDO apt-get install -y -qq --no-install-recommends -o Dpkg::Options::=--force-unsafe-io \
  "${missing[@]}"
