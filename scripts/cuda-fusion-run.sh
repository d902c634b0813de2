#!/usr/bin/env bash
# On a GPU machine with a CUDA LibTorch: compiles tensor_fusion.cc and
# compute_device.cc against it, links the tensor-fusion tests
# (tensor_fusion_test.cc, compute_device_test.cc), pf_fusion_bench and
# pf_recon_device_check with what scripts/cuda-fusion-pack.sh packed, runs
# the tests (CudaMatchesTheCpu included), the benchmark at three sizes and
# the whole reconstruction of the default synth clip on each device, and
# writes the log, the tests' XML and the JSON of the benchmark and the check
# to OUT_DIR. Needs g++ and, unless the three variables below are set,
# python3 with torch.
#
#   scripts/cuda-fusion-run.sh [PACK_DIR] [OUT_DIR]   (defaults: .cuda-pack /tmp/cuda-fusion)
#   TORCH_INCLUDES="DIR..." TORCH_LIBDIR=DIR TORCH_LIBS="-l..."   another LibTorch
#   RUN="tests bench recon"                                        what runs (default all)
#   RUNS=N DEVICES=cpu,cuda:0                    the flags of the benchmark and of the check
#   RECON_SIZES="768x576 1536x1152"              the check's clip sizes (default 768x576)
#
# OpenImageIO is not needed there: no image file is read or written, and the
# functions of it that our libraries call get stubs that abort, found by a
# first link of each program.
set -uo pipefail
PACK=$(realpath "${1:-.cuda-pack}")
OUT_DIR=${2:-/tmp/cuda-fusion}
WORK=$(mktemp -d)
mkdir -p "$OUT_DIR"
exec > >(tee "$OUT_DIR/log.txt") 2>&1
date -u
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv 2>&1 || true
if [ -z "${TORCH_LIBDIR:-}" ]; then
  torch_dir=$(python3 -c 'import torch, os; print(os.path.dirname(torch.__file__))') || exit 1
  python3 -c 'import torch; print("torch", torch.__version__, "CUDA", torch.version.cuda, "GPU", torch.cuda.is_available())'
  TORCH_INCLUDES="$torch_dir/include $torch_dir/include/torch/csrc/api/include"
  TORCH_LIBDIR=$torch_dir/lib
  TORCH_LIBS=${TORCH_LIBS:-"-ltorch_cuda -ltorch_cpu -ltorch -lc10_cuda -lc10"}
fi
TORCH_LIBS=${TORCH_LIBS:-"-ltorch_cpu -ltorch -lc10"}
g++ --version | head -1
flags="-O3 -std=c++20 -D_GLIBCXX_USE_CXX11_ABI=1 -DPF_HAVE_TORCH=1 -DFMT_SHARED -DSPDLOG_COMPILED_LIB
       -DSPDLOG_FMT_EXTERNAL -DSPDLOG_SHARED_LIB -I. -I$PACK/include"
for dir in $TORCH_INCLUDES; do flags="$flags -isystem $dir"; done
export LD_LIBRARY_PATH=$PACK/so:$TORCH_LIBDIR${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
start=$(date +%s)
g++ $flags -c engine/recon/tensor_fusion.cc -o "$WORK/tensor_fusion.o" & compile1=$!
g++ $flags -c engine/recon/compute_device.cc -o "$WORK/compute_device.o" & compile2=$!
wait $compile1 && wait $compile2 || { echo "compiling failed"; exit 1; }
echo "compiled in $(($(date +%s) - start)) s"
libs="$WORK/tensor_fusion.o $WORK/compute_device.o"
for lib in recon synth render clip image camera proto common; do libs="$libs $PACK/lib/libpf_$lib.a"; done
if [ -f "$PACK/lib/libcudart_static.a" ]; then libs="$libs $PACK/lib/libcudart_static.a -ldl -lrt"; fi
link="-L$TORCH_LIBDIR -Wl,--no-as-needed $TORCH_LIBS -Wl,--as-needed $(ls "$PACK"/so/libabsl_*)
      $PACK/so/libspdlog.so.1.10 $PACK/so/libfmt.so.9 $PACK/so/libprotobuf.so.32 -pthread
      -Wl,-rpath,$TORCH_LIBDIR:$PACK/so"
gtest="$PACK/lib/libgtest_main.a $PACK/lib/libgtest.a"
# Each program's own objects and libraries, before $libs.
declare -A programs=(
  [recon_cuda_test]="$PACK/obj/tensor_fusion_test.cc.o $PACK/obj/compute_device_test.cc.o $gtest"
  [pf_fusion_bench]="$PACK/obj/fusion_bench.cc.o"
  [pf_recon_device_check]="$PACK/obj/recon_device_check.cc.o")
for program in "${!programs[@]}"; do
  g++ -o "$WORK/probe" ${programs[$program]} $libs $link -Wl,--no-demangle 2>&1 |
    grep -o "undefined reference to \`[A-Za-z0-9_]*'" | sed "s/.*\`//; s/'//"
done | sort -u >"$WORK/missing.txt"
echo "stubbed $(wc -l <"$WORK/missing.txt") functions:"
c++filt <"$WORK/missing.txt" | sed 's/^/  /'
{
  echo '#include <stdio.h>'
  echo '#include <stdlib.h>'
  while read -r symbol; do
    echo "void $symbol(void) { fputs(\"stub reached: $symbol\\n\", stderr); abort(); }"
  done <"$WORK/missing.txt"
} >"$WORK/stubs.c"
gcc -c -fPIC "$WORK/stubs.c" -o "$WORK/stubs.o"
for program in "${!programs[@]}"; do
  g++ -o "$WORK/$program" ${programs[$program]} $libs "$WORK/stubs.o" $link ||
    { echo "linking $program failed"; exit 1; }
done
echo "linked in $(($(date +%s) - start)) s"
wants() { [[ " ${RUN:-tests bench recon} " == *" $1 "* ]]; }
rc=0
if wants tests; then
  "$WORK/recon_cuda_test" --gtest_output="xml:$OUT_DIR/recon_cuda_test.xml" || rc=1
  echo "tests: exit status $rc"
fi
if wants bench; then
  bench() { "$WORK/pf_fusion_bench" --runs "${RUNS:-3}" --devices "${DEVICES:-cpu,cuda:0}" "$@"; }
  bench | tee "$OUT_DIR/bench_default.json"
  bench --queries_per_view 400000 | tee "$OUT_DIR/bench_4x.json"
  bench --views 24 --width 1936 --height 1216 --queries_per_view 200000 | tee "$OUT_DIR/bench_dgp_size.json"
fi
if wants recon; then
  for size in ${RECON_SIZES:-768x576}; do
    "$WORK/pf_recon_device_check" --runs "${RUNS:-3}" --devices "${DEVICES:-cpu,cuda:0}" \
      --width "${size%x*}" --height "${size#*x}" | tee "$OUT_DIR/recon_check_$size.json"
    check_rc=${PIPESTATUS[0]}
    echo "recon check at $size: exit status $check_rc ($(($(date +%s) - start)) s)"
    [ "$check_rc" = 0 ] || rc=1
  done
fi
echo "done in $(($(date +%s) - start)) s"
exit $rc
