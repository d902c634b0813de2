#!/usr/bin/env bash
# Packs what a machine with a CUDA LibTorch (for instance PyTorch's Python
# wheel) but none of our other dependencies needs to run the tensor-fusion
# tests, pf_fusion_bench and pf_recon_device_check (the whole reconstruction)
# on its GPU, with scripts/cuda-fusion-run.sh: our static libraries without
# the two files that include LibTorch (tensor_fusion.cc and
# compute_device.cc, which the run script compiles there), the test,
# benchmark and check objects, the headers those two files need beyond
# LibTorch's (absl, protobuf, spdlog, fmt, our generated protos), and
# Debian's absl, spdlog, fmt and protobuf shared libraries by soname with
# what they need in turn. About 20 MB.
#
#   scripts/cuda-fusion-pack.sh [BUILD_DIR] [PACK_DIR]   (defaults: build .cuda-pack)
#
# BUILD_DIR must hold a build with LibTorch (tests/recon_test,
# bin/pf_fusion_bench and bin/pf_recon_device_check built). PACK_DIR is
# git-ignored; copy it, with the source tree, to the GPU machine.
set -euo pipefail
BUILD=${1:-build}
PACK=${2:-.cuda-pack}
rm -rf "$PACK"
mkdir -p "$PACK"/lib "$PACK"/obj "$PACK"/so "$PACK"/include
for a in engine/recon/libpf_recon.a engine/synth/libpf_synth.a \
         engine/render/libpf_render.a engine/clip/libpf_clip.a \
         engine/image/libpf_image.a engine/camera/libpf_camera.a \
         proto/libpf_proto.a common/libpf_common.a; do
  cp "$BUILD/$a" "$PACK/lib/"
done
ar d "$PACK/lib/libpf_recon.a" tensor_fusion.cc.o compute_device.cc.o
cp /usr/lib/x86_64-linux-gnu/libgtest.a /usr/lib/x86_64-linux-gnu/libgtest_main.a "$PACK/lib/"
# A build with the CUDA rasterizer in libpf_render.a needs the CUDA runtime
# it was compiled against.
cudart=$(dirname "$(command -v nvcc 2>/dev/null || echo /usr/local/cuda/bin/nvcc)")/../lib64/libcudart_static.a
if [ -f "$cudart" ]; then cp "$cudart" "$PACK/lib/"; fi
strip --strip-debug "$PACK"/lib/*.a
objects="$BUILD/engine/recon/CMakeFiles"
cp "$objects/recon_test.dir/tensor_fusion_test.cc.o" "$objects/recon_test.dir/compute_device_test.cc.o" \
   "$BUILD/bench/CMakeFiles/pf_fusion_bench.dir/fusion_bench.cc.o" \
   "$objects/pf_recon_device_check.dir/recon_device_check.cc.o" "$PACK/obj/"
strip --strip-debug "$PACK"/obj/*.o
cp -r /usr/include/absl /usr/include/google /usr/include/spdlog /usr/include/fmt "$PACK/include/"
cp -r "$BUILD/proto_gen/pointforward" "$PACK/include/"
find "$PACK/include" -type f ! -name '*.h' ! -name '*.inc' ! -name '*.hpp' -delete
libs="$(ls /usr/lib/x86_64-linux-gnu/libabsl_*.so.20220623.0.0) /usr/lib/x86_64-linux-gnu/libspdlog.so.1.10.0
      /usr/lib/x86_64-linux-gnu/libfmt.so.9.1.0 /usr/lib/x86_64-linux-gnu/libprotobuf.so.32"
for lib in $libs $(for l in $libs; do ldd "$l" | awk '/=>/ {print $3}'; done | sort -u); do
  case $(basename "$lib") in
    libc.so* | libm.so* | libstdc++* | libgcc_s* | ld-linux* | libpthread* | libdl.so* | librt.so*) continue ;;
  esac
  soname=$(objdump -p "$lib" | awk '/SONAME/ {print $2}')
  cp -L "$lib" "$PACK/so/${soname:-$(basename "$lib")}"
done
du -sh "$PACK"
