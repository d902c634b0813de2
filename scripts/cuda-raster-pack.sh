#!/usr/bin/env bash
# Packs what a GPU machine without our dependencies needs to run the CUDA
# rasterizer's checks (scripts/cuda-raster-run.sh): cuda_rasterizer_test and
# pf_raster_bench from a build with CUDA (CMake found nvcc), stripped, and
# the shared libraries they load beyond the C and C++ runtimes (abseil,
# protobuf, spdlog, fmt, zlib), by soname. The CUDA runtime is linked in
# statically; the GPU driver is the machine's own. About 15 MB.
#
#   scripts/cuda-raster-pack.sh [BUILD_DIR] [PACK_DIR]   (defaults: build .cuda-raster)
#
# PACK_DIR is git-ignored; the device tool carries it with the source tree.
set -euo pipefail
BUILD=${1:-build}
PACK=${2:-.cuda-raster}
cmake --build "$BUILD" --target cuda_rasterizer_test pf_raster_bench >/dev/null
nm -C "$BUILD/bin/pf_raster_bench" | grep -c ProjectKernel >/dev/null ||
  { echo "$BUILD has no CUDA rasterizer (configure where nvcc is on PATH)" >&2; exit 1; }
rm -rf "$PACK"
mkdir -p "$PACK/so"
cp "$BUILD/tests/cuda_rasterizer_test" "$BUILD/bin/pf_raster_bench" "$PACK/"
strip --strip-debug "$PACK/cuda_rasterizer_test" "$PACK/pf_raster_bench"
for lib in $(ldd "$PACK/cuda_rasterizer_test" "$PACK/pf_raster_bench" | awk '/=>/ {print $3}' |
             sort -u); do
  case $(basename "$lib") in
    libc.so* | libm.so* | libstdc++* | libgcc_s* | ld-linux* | libpthread* | libdl.so* | librt.so*) continue ;;
  esac
  cp -L "$lib" "$PACK/so/$(basename "$lib")"
done
du -sh "$PACK"
