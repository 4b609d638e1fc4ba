#!/usr/bin/env bash
# Installs every Debian 12 package that Horizon's build, tests and demo need.
# Idempotent: when all of them are already installed it touches nothing (no
# apt-get at all). Packages come from Debian's own archive only. Uses sudo
# when not run as root.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

packages=(
  # build
  cmake ninja-build g++ pkg-config
  ccache  # scripts/compiler_cache.sh: every build directory and clone on a machine shares one cache
  # engine libraries
  libboost-dev nlohmann-json3-dev libgeographiclib-dev
  libopenimageio-dev
  openimageio-tools  # OpenImageIO's CMake package refuses to load without its tools (/usr/bin/iconvert)
  libgeotiff-dev libtiff-dev libdeflate-dev zlib1g-dev  # the GeoTIFF writer deflates tiles on every core (libdeflate; zlib for 8-bit codes)
  libproj-dev proj-data  # CRSs and their transformations (PROJ 9.1); proj-data holds proj.db and the datum grids
  libcgal-dev  # TINs: exact predicates, Delaunay triangulation, OBJ/PLY readers (header-only; brings GMP, MPFR)
  # GPU path (EGL, headless Mesa)
  libegl-dev libegl-mesa0 libgl1-mesa-dri libgles-dev libopengl-dev libgl-dev
  # daemon
  libgrpc++-dev libprotobuf-dev protobuf-compiler protobuf-compiler-grpc
  prometheus-cpp-dev  # horizond's /metrics (core + pull)
  libssl-dev  # datasets.NAME.sha256: the DEM checked against its digest on load (OpenSSL EVP)
  # the daemon's integration tests: an independent Python client, and the deploy YAML check
  python3-grpcio python3-protobuf python3-yaml
  # fuzzing (scripts/fuzz.sh): clang and its libFuzzer runtime
  clang-14 libclang-rt-14-dev
  # replicas behind a real gRPC load balancer (tests/bench/scale_out.sh), the certificates of the TLS tests
  haproxy curl openssl
  # tests and benchmarks; gdal-bin gives gdalinfo (georeferencing checks), gdal_translate, gdalwarp and
  # gdaltransform (the CRS tests' files and reference coordinates) and gdal_viewshed (the speed peer)
  libgtest-dev libbenchmark-dev gdal-bin python3
  # horizon bench: GRASS r.viewshed (the exact peer) and the chart's font (OpenImageIO render_text, DejaVu Sans)
  grass-core fonts-dejavu-core
  # the QGIS Processing provider (clients/qgis), tested headless in PyQGIS (QGIS 3.22, offscreen Qt);
  # python3-qgis brings qgis-providers and the Processing framework, not the desktop application
  python3-qgis python3-numpy
)

missing=()
for package in "${packages[@]}"; do
  status="$(dpkg-query -W -f='${db:Status-Status}' "$package" 2>/dev/null || true)"
  [[ "$status" == "installed" ]] || missing+=("$package")
done

# buf (buf curl, the daemon's reflection client test) comes from the npm
# registry: Debian has no package of it. npm itself from Debian when absent.
buf_version=1.75.0
need_buf=0
if ! command -v buf >/dev/null 2>&1 || [[ "$(buf --version 2>/dev/null)" != "$buf_version" ]]; then
  need_buf=1
  command -v npm >/dev/null 2>&1 || missing+=(nodejs npm)
fi

if ((${#missing[@]} == 0 && need_buf == 0)); then
  echo "setup: all ${#packages[@]} packages and buf $buf_version are installed"
  exit 0
fi

sudo=()
if [[ "$(id -u)" -ne 0 ]]; then
  if ! command -v sudo >/dev/null 2>&1; then
    echo "setup: need root or sudo to install: ${missing[*]} $( ((need_buf)) && echo buf)" >&2
    exit 1
  fi
  sudo=(sudo)
fi

if ((${#missing[@]} > 0)); then
  echo "setup: installing ${missing[*]}"
  "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update
  "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "${missing[@]}"
fi

if ((need_buf)); then
  echo "setup: installing buf $buf_version (npm @bufbuild/buf)"
  "${sudo[@]}" npm install --global --no-fund --no-audit "@bufbuild/buf@$buf_version"
fi
