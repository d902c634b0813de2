#!/usr/bin/env bash
# Packs what a GPU machine without our dependencies needs to run the CUDA
# rasterizer's and colour fit's checks (scripts/cuda-raster-run.sh):
# cuda_rasterizer_test, cuda_colour_fit_test and pf_raster_bench from a build
# with CUDA (CMake found nvcc), stripped, and the shared libraries they load
# beyond the C and C++ runtimes (abseil, protobuf, spdlog, fmt, zlib), by
# soname. The colour fit's test calls nothing of LibTorch, which the
# library it links names anyway: that entry is dropped (patchelf). The CUDA
# runtime is linked in statically; the GPU driver is the machine's own.
# About 25 MB.
#
#   scripts/cuda-raster-pack.sh [BUILD_DIR] [PACK_DIR]   (defaults: build .cuda-raster)
#
# PACK_DIR is git-ignored; the device tool carries it with the source tree.
set -euo pipefail
BUILD=${1:-build}
PACK=${2:-.cuda-raster}
command -v patchelf >/dev/null || { echo "needs patchelf (apt-get install patchelf)" >&2; exit 1; }
cmake --build "$BUILD" --target cuda_rasterizer_test cuda_colour_fit_test pf_raster_bench >/dev/null
nm -C "$BUILD/bin/pf_raster_bench" | grep -c ProjectKernel >/dev/null ||
  { echo "$BUILD has no CUDA rasterizer (configure where nvcc is on PATH)" >&2; exit 1; }
rm -rf "$PACK"
mkdir -p "$PACK/so"
programs="cuda_rasterizer_test cuda_colour_fit_test pf_raster_bench"
cp "$BUILD/tests/cuda_rasterizer_test" "$BUILD/tests/cuda_colour_fit_test" \
   "$BUILD/bin/pf_raster_bench" "$PACK/"
for program in $programs; do
  strip --strip-debug "$PACK/$program"
  if nm -D --undefined-only "$PACK/$program" | grep -q -E 'torch|c10|at::'; then
    echo "$program calls LibTorch" >&2
    exit 1
  fi
  for torch in $(readelf -d "$PACK/$program" | grep -o -E '\[lib(torch|c10)[^]]*' | tr -d '['); do
    patchelf --remove-needed "$torch" "$PACK/$program"
  done
done
for lib in $(cd "$PACK" && ldd $programs | awk '/=>/ {print $3}' | sort -u); do
  case $(basename "$lib") in
    libc.so* | libm.so* | libstdc++* | libgcc_s* | ld-linux* | libpthread* | libdl.so* | librt.so*) continue ;;
  esac
  cp -L "$lib" "$PACK/so/$(basename "$lib")"
done
du -sh "$PACK"
