#!/usr/bin/env bash
# Installs the Debian 12 packages that the build, the tests and the demo need.
# Idempotent: prints nothing and changes nothing when everything is present.
# Run as root (or with sudo available). The package list is the one place the
# project's dependencies are named; the Dockerfile calls this script too.
set -euo pipefail

PACKAGES=(
  # Toolchain.
  build-essential cmake ninja-build ccache pkg-config clang-format
  # clang and its runtime (libFuzzer) for `make fuzz-smoke` (fuzz/).
  clang libclang-rt-14-dev
  # Libraries.
  libabsl-dev libprotobuf-dev protobuf-compiler libspdlog-dev libgtest-dev
  libopenimageio-dev libopenexr-dev nlohmann-json3-dev zlib1g-dev
  # OpenImageIO's CMake config checks for files of these two: its command-line
  # tools (/usr/bin/iconvert, ...) and /usr/include/opencv4.
  openimageio-tools libopencv-core-dev
  # The service: gRPC and its code generators, Google's common protos
  # (google/longrunning, google/rpc; extracted from the jar at configure
  # time), SQLite for the embedded job store.
  libgrpc++-dev protobuf-compiler-grpc libgoogle-common-protos-java libsqlite3-dev
  # PostgreSQL job store: libpq (the client library the store links), and the
  # server itself, which the tests run as a throwaway instance (initdb in a
  # temporary directory, as the `postgres` user).
  libpq-dev postgresql
  # LibTorch (CPU) for fusion's tensor work (engine/recon/
  # tensor_fusion.h), and the threaded OpenBLAS it should load instead of
  # the reference BLAS.
  libtorch-dev libopenblas0-pthread
  # Python: the demo's views file, the example client (grpc, protobuf
  # and OpenImageIO bindings), and pandas for `pf import pandaset`, whose
  # LiDAR and cuboid files are pickled DataFrames
  # (engine/importers/pandaset_pickles.py).
  python3 python3-grpcio python3-protobuf python3-openimageio python3-pandas
  # Checks of the deployment files (tests/deploy_files_test.py): yamllint,
  # and PyYAML to read the Kubernetes manifests.
  yamllint python3-yaml
  # TLS tests (tests/auth_e2e_test.cc): a throwaway CA and certificates made
  # with the openssl command line at test time.
  openssl
)

missing=()
for pkg in "${PACKAGES[@]}"; do
  status=$(dpkg-query -W -f='${db:Status-Status}' "$pkg" 2>/dev/null || true)
  [[ "$status" == "installed" ]] || missing+=("$pkg")
done
[[ ${#missing[@]} -eq 0 ]] && exit 0

SUDO=()
if [[ $(id -u) -ne 0 ]]; then
  if command -v sudo >/dev/null 2>&1; then
    SUDO=(sudo)
  else
    echo "install-deps: missing packages (${missing[*]}); run this script as root" >&2
    exit 1
  fi
fi
echo "install-deps: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
"${SUDO[@]}" apt-get update -q >&2
"${SUDO[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}" >&2
