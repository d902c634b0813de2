# PointForward container images: pf-server and pf-worker (CPU engine).
#
#   docker build --target server -t pointforward/pf-server:dev .
#   docker build --target worker -t pointforward/pf-worker:dev .
#
# `docker build .` without --target builds `server` (the last stage). Both
# images hold all three binaries (pf, pf-server, pf-worker); they differ only
# in their ENTRYPOINT, so `docker run --entrypoint pf ...` also works.
#
# The build stage installs exactly what the README's `make test` / `make demo`
# install (scripts/install-deps.sh, the one list of packages) and builds with
# the Makefile's configure line, in Release. tests/deploy_files_test.py checks
# that this file keeps doing so. See docs/DEPLOY.md.
#
# No HEALTHCHECK: the health check is grpc.health.v1 on port 50051 and the
# image carries no gRPC client to call it. Kubernetes probes it natively
# (`grpc:` probes, deploy/k8s/base/server-deployment.yaml); pf-worker has no
# gRPC port and is probed on its metrics port (/healthz).

# -- Build ---------------------------------------------------------------------
FROM debian:bookworm AS build
WORKDIR /src
# The install script alone first, so the package layer is rebuilt only when
# the package list changes. It runs as root here, as the README asks.
COPY scripts/install-deps.sh scripts/install-deps.sh
RUN scripts/install-deps.sh && rm -rf /var/lib/apt/lists/*
COPY . .
RUN cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release \
 && ninja -C build pf pf-server pf-worker

# -- Runtime (shared by both targets) --------------------------------------------
FROM debian:bookworm-slim AS runtime
# Only the shared libraries the binaries load. Derived from the DT_NEEDED
# entries of build/bin/{pf,pf-server,pf-worker} (`readelf -d`, then `dpkg -S`
# on each library `ldd` resolves); apt brings their own dependencies:
#   libabsl_*.so.20220623            -> libabsl20220623
#   libprotobuf.so.32                -> libprotobuf32
#   libgrpc++.so.1.51, libgrpc++_reflection.so.1.51 -> libgrpc++1.51
#   libgpr.so.29 (and libgrpc.so.29) -> libgrpc29
#   libspdlog.so.1.10                -> libspdlog1.10
#   libfmt.so.9                      -> libfmt9
#   libOpenImageIO{,_Util}.so.2.4    -> libopenimageio2.4
#   libsqlite3.so.0                  -> libsqlite3-0   (embedded job store)
#   libpq.so.5                       -> libpq5         (PostgreSQL job store)
#   libz.so.1                        -> zlib1g
#   libtorch_cpu.so.1.13, libc10.so.1.13 -> libtorch1.13 (fusion's tensor work;
#                                       libopenblas0-pthread: its BLAS)
#   libstdc++.so.6, libgcc_s.so.1    -> libstdc++6, libgcc-s1 (libc6: in the base)
RUN apt-get update \
 && apt-get install -y --no-install-recommends \
      libabsl20220623 libprotobuf32 libgrpc++1.51 libgrpc29 libspdlog1.10 libfmt9 \
      libopenimageio2.4 libsqlite3-0 libpq5 zlib1g libstdc++6 libgcc-s1 \
      libtorch1.13 libopenblas0-pthread \
 && rm -rf /var/lib/apt/lists/*
COPY --from=build /src/build/bin/pf /src/build/bin/pf-server /src/build/bin/pf-worker /usr/local/bin/
# `pf import pandaset` runs its pickle reader from beside the pf binary. The
# reader needs python3 and python3-pandas, which this image leaves out (the
# server and worker never import): pf then says which package to install.
COPY --from=build /src/build/bin/pandaset_pickles.py /usr/local/bin/
# A non-root user; /var/lib/pf (the SQLite file and blob directory of a
# single-container run, or the mount point of the shared blob volume) is its
# own, so a fresh named volume mounted there inherits the ownership.
RUN groupadd --gid 10001 pf \
 && useradd --uid 10001 --gid 10001 --home-dir /var/lib/pf --no-create-home \
      --shell /usr/sbin/nologin pf \
 && mkdir -p /var/lib/pf/blobs \
 && chown -R 10001:10001 /var/lib/pf
WORKDIR /var/lib/pf
# By name here; the Kubernetes manifests also set runAsUser: 10001, since
# runAsNonRoot can only verify a numeric user.
USER pf
# Metrics of either process: Prometheus text at http://HOST:9090/metrics.
ENV PF_METRICS_LISTEN=0.0.0.0:9090

# -- pf-worker -------------------------------------------------------------------
# Needs the server address: `--server HOST:PORT` or PF_SERVER. SIGTERM (docker
# stop, Kubernetes) lets it finish its task first: give it a long grace period.
FROM runtime AS worker
EXPOSE 9090
ENTRYPOINT ["pf-worker"]

# -- pf-server (default target) ----------------------------------------------------
# Defaults to SQLite and blobs under /var/lib/pf; set PF_STORE to a
# postgresql:// URI to share one job store between replicas.
FROM runtime AS server
ENV PF_LISTEN=0.0.0.0:50051 \
    PF_STORE=sqlite:/var/lib/pf/jobs.db \
    PF_BLOBS=/var/lib/pf/blobs
EXPOSE 50051 9090
ENTRYPOINT ["pf-server"]
