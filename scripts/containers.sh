#!/usr/bin/env bash
# Builds the PointForward images with podman, without a registry, and checks
# them running (docs/DEPLOY.md, "Containers without a registry"):
#
#   scripts/containers.sh [build] [check] [compose] [--out DIR] [--pf PATH]
#
#   build    makes the base image debian:bookworm with debootstrap when podman
#            has none, then builds pf-server and pf-worker from the Dockerfile
#            (and says why the GPU image cannot be built here)
#   check    a pf-server container (SQLite on a volume) and two pf-worker
#            containers on the host network; a clip made on the host is
#            reconstructed and rendered through `pf --server`; the same render
#            with 4 workers; a worker killed mid-job; the server restarted
#            mid-job. Every output of the fault runs is compared with the
#            run without faults.
#   compose  deploy/compose.yaml under docker-compose against podman's API:
#            PostgreSQL, two servers, 2 then 4 workers, a render through each
#            server
#
# No step given: all three. Needs root, podman, runc and debootstrap
# (apt-get install podman runc debootstrap), and docker-compose for the
# compose step (apt-get install --no-install-recommends docker-compose); `pf` on the host
# (default build/bin/pf) submits the work. Figures are printed as
# `containers: KEY VALUE` lines and written to DIR/figures.json (DIR default
# containers-out). Exit status: 0 every step passed, 1 a step failed, 2 bad
# usage, 77 podman or its runtime missing, or `check` without the images
# (ctest's skip code).
set -eEuo pipefail
trap 'echo "containers: failed at line $LINENO: $BASH_COMMAND" >&2' ERR
cd "$(dirname "$0")/.."
ROOT=$(pwd)

OUT=containers-out
PF=build/bin/pf
STEPS=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    build | check | compose) STEPS+=("$1") ;;
    --out) OUT=$2; shift ;;
    --pf) PF=$2; shift ;;
    -h | --help) awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "$0"; exit 0 ;;
    *) echo "containers: unknown argument '$1' (expected build, check, compose, --out DIR, --pf PATH)" >&2; exit 2 ;;
  esac
  shift
done
[[ ${#STEPS[@]} -gt 0 ]] || STEPS=(build check compose)

SERVER_IMAGE=localhost/pointforward/pf-server:dev
WORKER_IMAGE=localhost/pointforward/pf-worker:dev
BASE_IMAGE=docker.io/library/debian:bookworm
SLIM_IMAGE=docker.io/library/debian:bookworm-slim
PREFIX=pfc  # Names of the check's containers and volume.

say() { echo "containers: $*"; }
die() { echo "containers: $*" >&2; exit 1; }
FIGURES=()
figure() {  # KEY VALUE (a number, or a JSON string)
  say "$1 $2"
  FIGURES+=("\"$1\": $2")
}
write_figures() {
  mkdir -p "$OUT"
  { echo "{"; local IFS=$'\n'; echo "${FIGURES[*]}" | sed '$!s/$/,/; s/^/  /'; echo "}"; } \
    >"$OUT/figures.json"
}

if [[ $(id -u) -ne 0 ]]; then
  echo "containers: run as root (podman's runc runtime and debootstrap need it here)" >&2
  exit 77
fi
for tool in podman runc; do
  if ! command -v "$tool" >/dev/null 2>&1; then
    echo "containers: $tool not found; install it: apt-get install podman runc debootstrap" >&2
    exit 77
  fi
done

# The settings podman needs on these VMs: crun fails here, runc works; no
# default ulimits (the VM refuses podman's); cgroupfs, not systemd.
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
cat >"$OUT/containers.conf" <<'EOF'
[containers]
default_ulimits = []
[engine]
cgroup_manager = "cgroupfs"
runtime = "runc"
EOF
export CONTAINERS_CONF=$OUT/containers.conf
P=(podman --runtime runc)

now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }'; }

# -- build --------------------------------------------------------------------------
base_image() {
  if "${P[@]}" image exists "$BASE_IMAGE"; then
    say "base image $BASE_IMAGE present"
  else
    command -v debootstrap >/dev/null 2>&1 ||
      die "debootstrap not found (apt-get install debootstrap): it makes the base image, as no registry is reachable"
    local sources=/etc/apt/sources.list.d/debian.sources
    [[ -f $sources ]] || die "$sources not found: the base image takes its Debian mirror from it"
    local mirror
    mirror=$(awk '/^URIs:/ { print $2; exit }' "$sources")
    local rootfs
    rootfs=$(mktemp -d /var/tmp/pf-rootfs.XXXXXX)
    local start
    start=$(now)
    say "making $BASE_IMAGE: debootstrap --variant=minbase bookworm from $mirror"
    debootstrap --variant=minbase bookworm "$rootfs" "$mirror" >"$OUT/debootstrap.log" 2>&1 ||
      { rm -rf "$rootfs"; die "debootstrap failed; see $OUT/debootstrap.log"; }
    # The host's sources (updates and security too), so that the image's
    # packages are those the host builds and tests with.
    rm -f "$rootfs/etc/apt/sources.list"
    cp "$sources" "$rootfs/etc/apt/sources.list.d/"
    rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/lib/apt/lists/*
    tar -C "$rootfs" -c . | "${P[@]}" import - "$BASE_IMAGE" >/dev/null
    rm -rf "$rootfs"
    figure baseImageSeconds "$(elapsed "$start")"
  fi
  # The runtime stage's debian:bookworm-slim: the same minimal base.
  "${P[@]}" image exists "$SLIM_IMAGE" || "${P[@]}" tag "$BASE_IMAGE" "$SLIM_IMAGE"
}

image_mib() {
  "${P[@]}" image inspect --format '{{.Size}}' "$1" | awk '{ printf "%.0f", $1 / 1048576 }'
}

build_images() {
  base_image
  local commit
  commit=$(git rev-parse HEAD 2>/dev/null || echo unknown)
  git diff --quiet HEAD 2>/dev/null || commit="$commit-dirty"
  # Both images from one snapshot of the tree (tracked and untracked files git
  # does not ignore): edits made while they build change neither, and the
  # second build reuses the first one's layers.
  CONTEXT=$(mktemp -d /var/tmp/pf-context.XXXXXX)
  trap 'rm -rf "$CONTEXT"' EXIT
  git ls-files -z -co --exclude-standard | tar --null -T - -c | tar -x -C "$CONTEXT"
  for target in server worker; do
    local image=$SERVER_IMAGE
    [[ $target == worker ]] && image=$WORKER_IMAGE
    local start
    start=$(now)
    say "building $image (podman build --target $target; log $OUT/build-$target.log)"
    "${P[@]}" build --network host --target "$target" --label "pf.commit=$commit" -t "$image" \
      "$CONTEXT" >"$OUT/build-$target.log" 2>&1 ||
      die "podman build --target $target failed; see $OUT/build-$target.log"
    figure "${target}BuildSeconds" "$(elapsed "$start")"
    figure "${target}ImageMiB" "$(image_mib "$image")"
  done
  # The base the runtime images add their libraries to.
  figure baseImageMiB "$(image_mib "$SLIM_IMAGE")"
  # The GPU image starts from NVIDIA's apt repository and PyTorch's LibTorch
  # download; neither is reachable from here.
  local unreachable=()
  for url in https://developer.download.nvidia.com https://download.pytorch.org; do
    curl -fsS -m 10 -o /dev/null "$url" 2>/dev/null || unreachable+=("$url")
  done
  if [[ ${#unreachable[@]} -gt 0 ]]; then
    say "GPU image (deploy/gpu/Dockerfile.gpu) not built: ${unreachable[*]} not reachable from this machine"
    figure gpuImage '"not built: its CUDA packages and LibTorch are not reachable"'
  else
    local start
    start=$(now)
    "${P[@]}" build --network host -f "$CONTEXT/deploy/gpu/Dockerfile.gpu" \
      -t localhost/pointforward/pf-worker-gpu:dev "$CONTEXT" \
      >"$OUT/build-gpu.log" 2>&1 || die "podman build of deploy/gpu/Dockerfile.gpu failed; see $OUT/build-gpu.log"
    figure gpuBuildSeconds "$(elapsed "$start")"
    figure gpuImageMiB "$(image_mib localhost/pointforward/pf-worker-gpu:dev)"
  fi
  rm -rf "$CONTEXT"
  trap - EXIT
}

# -- check --------------------------------------------------------------------------
free_port() {
  /usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}

# Removes the containers whose names start with $1.
remove_containers() {
  local names
  names=$("${P[@]}" ps -a --format '{{.Names}}' | grep "^$1" || true)
  [[ -z $names ]] || "${P[@]}" rm -f -t 2 $names >/dev/null 2>&1 || true
}

cleanup_check() {
  remove_containers "$PREFIX-"
  "${P[@]}" volume rm -f "$PREFIX-data" >/dev/null 2>&1 || true
}

start_server() {
  "${P[@]}" run -d --name "$PREFIX-server" --network host -v "$PREFIX-data:/var/lib/pf" \
    -e PF_LISTEN="127.0.0.1:$PORT" -e PF_METRICS_LISTEN="127.0.0.1:$(free_port)" \
    -e PF_LEASE_SECONDS=5 "$SERVER_IMAGE" >/dev/null
}

# wait_server ADDR CONTAINER SECONDS: waits for the pf-server in CONTAINER
# to answer on ADDR; else shows its log and fails.
wait_server() {
  for _ in $(seq $(($3 * 5))); do
    "$PF" --server "$1" scene list >/dev/null 2>&1 && return 0
    sleep 0.2
  done
  "${P[@]}" logs "$2" >&2 || true
  die "the pf-server container $2 did not answer on $1 within $3 s"
}

# start_worker N [STAGE_DELAY_MS]
start_worker() {
  "${P[@]}" run -d --name "$PREFIX-worker-$1" --network host \
    -e PF_SERVER="$ADDR" -e PF_WORKER_ID="ctr-w$1" -e PF_METRICS_LISTEN="127.0.0.1:$(free_port)" \
    -e PF_STAGE_DELAY_MS="${2:-0}" "$WORKER_IMAGE" >/dev/null
}

# render NAME: the scene rendered with the check's views into $OUT/NAME,
# waited for; prints the seconds it took.
render_wait() {
  local start
  start=$(now)
  "$PF" --server "$ADDR" render "$SCENE" --cameras "$OUT/views.json" --out "$OUT/$1" \
    --chunk-frames 2 --wait >"$OUT/$1.log" 2>&1 || { cat "$OUT/$1.log" >&2; die "render $1 failed"; }
  elapsed "$start"
}

# The job's outputs against the run without faults: the same files, each
# present once; PNGs byte-identical; EXRs with identical pixels in every
# channel (their DateTime attribute is the time of writing); manifests equal
# but for the job's name and the render times.
same_outputs() {
  local a=$OUT/$1 b=$OUT/$2
  diff <(cd "$a" && find . -type f ! -name '*.log' | sort) <(cd "$b" && find . -type f ! -name '*.log' | sort) \
    >/dev/null || die "$2 has other files than $1"
  local f
  for f in "$a"/*.png; do
    cmp -s "$f" "$b/${f##*/}" || die "$2: ${f##*/} differs from $1's"
  done
  for f in "$a"/*.exr; do
    idiff -q -fail 0 -warn 0 "$f" "$b/${f##*/}" >/dev/null 2>&1 || die "$2: ${f##*/} has other pixels than $1's"
  done
  /usr/bin/python3 - "$a/manifest.json" "$b/manifest.json" <<'PY' || die "$2: manifest.json differs from $1's"
import json, sys
def strip(x):
    if isinstance(x, dict):
        return {k: strip(v) for k, v in x.items() if k not in ("renderJob", "renderMs")}
    if isinstance(x, list):
        return [strip(v) for v in x]
    return x
a, b = (strip(json.load(open(p))) for p in sys.argv[1:3])
sys.exit(0 if a == b else 1)
PY
}

# busy_worker SINCE: the worker container that logged leasing a render task
# after SINCE (a time podman logs --since takes).
busy_worker() {
  for _ in $(seq 300); do
    for name in $("${P[@]}" ps --format '{{.Names}}' | grep "^$PREFIX-worker-"); do
      if "${P[@]}" logs --since "$1" "$name" 2>&1 | grep -q "leased .*render views"; then
        echo "$name"
        return 0
      fi
    done
    sleep 0.1
  done
  die "no worker leased a render task within 30 s"
}

check() {
  for image in "$SERVER_IMAGE" "$WORKER_IMAGE"; do
    if ! "${P[@]}" image exists "$image"; then
      echo "containers: $image not built: run scripts/containers.sh build (about 25 min)" >&2
      exit 77
    fi
  done
  [[ -x $PF ]] || die "$PF not found: build it (make build) or pass --pf PATH"
  say "images built from $("${P[@]}" image inspect --format '{{index .Labels "pf.commit"}}' "$SERVER_IMAGE")"
  cleanup_check
  trap cleanup_check EXIT
  rm -rf "$OUT/clip" "$OUT"/run-*
  PORT=$(free_port)
  ADDR=127.0.0.1:$PORT

  # A clip and 16 views (4 poses x 4 lane shifts), made on the host.
  "$PF" synth --out "$OUT/clip" --seed 1 >"$OUT/synth.log" 2>&1 ||
    { cat "$OUT/synth.log" >&2; die "pf synth failed"; }
  /usr/bin/python3 - "$OUT/clip/clip.json" "$OUT/views.json" <<'PY'
import json, sys
clip = json.load(open(sys.argv[1]))
cam = clip["cameras"][0]
frames = [f for f in clip["frames"] if f["camera"] == cam["id"]]
views = []
for f in frames[::5][:4]:
    m = [float(v) for v in f["worldFromCamera"]]
    for shift in range(4):
        shifted = list(m)
        for row in range(3):
            shifted[4 * row + 3] -= shift * m[4 * row]
        views.append({"camera": cam["id"], "timestampUs": int(f.get("timestampUs", 0)),
                      "worldFromCamera": shifted, "name": f"v{len(views):02d}"})
json.dump({"cameras": [cam], "views": views}, open(sys.argv[2], "w"), indent=1)
PY

  start_server
  wait_server "$ADDR" "$PREFIX-server" 30
  start_worker 1
  start_worker 2
  say "pf-server container on $ADDR, 2 pf-worker containers"

  local start
  start=$(now)
  "$PF" --server "$ADDR" scene create "$OUT/clip/clip.json" --wait >"$OUT/create.log" 2>&1 ||
    { cat "$OUT/create.log" >&2; die "scene create failed"; }
  figure reconstructSeconds "$(elapsed "$start")"
  SCENE=$(grep -o 'scenes/[0-9a-f]*' "$OUT/create.log" | head -1 || true)
  [[ -n $SCENE ]] || die "scene create printed no scene name (see $OUT/create.log)"

  local two four
  two=$(render_wait run-2-workers)
  figure render2WorkersSeconds "$two"
  start_worker 3
  start_worker 4
  four=$(render_wait run-4-workers)
  figure render4WorkersSeconds "$four"
  figure throughput4Over2 "$(awk -v a="$two" -v b="$four" 'BEGIN { printf "%.2f", a / b }')"
  same_outputs run-2-workers run-4-workers
  local count
  count=$(find "$OUT/run-2-workers" -name '*.exr' | wc -l)
  figure exrPerJob "$count"
  [[ $count -eq 16 ]] || die "a render job wrote $count EXRs, expected 16"

  # Faults: workers that report progress slowly enough to be caught mid-task.
  remove_containers "$PREFIX-worker-"
  start_worker 1 1000
  start_worker 2 1000
  local job victim since
  since=$(date -u +%Y-%m-%dT%H:%M:%S.%NZ)
  "$PF" --server "$ADDR" render "$SCENE" --cameras "$OUT/views.json" --chunk-frames 2 \
    >"$OUT/submit-kill.log" 2>&1 || { cat "$OUT/submit-kill.log" >&2; die "render submit failed"; }
  job=$(grep -o 'operations/[0-9a-f]*' "$OUT/submit-kill.log" | head -1 || true)
  [[ -n $job ]] || die "render submit printed no operation (see $OUT/submit-kill.log)"
  victim=$(busy_worker "$since")
  "${P[@]}" kill "$victim" >/dev/null
  say "killed $victim (podman kill) while it held a task of $job"
  start=$(now)
  "$PF" --server "$ADDR" jobs wait "$job" --out "$OUT/run-worker-killed" >"$OUT/run-worker-killed.log" 2>&1 ||
    { cat "$OUT/run-worker-killed.log" >&2; die "$job failed after a worker was killed"; }
  figure workerKilledJobSeconds "$(elapsed "$start")"
  same_outputs run-2-workers run-worker-killed
  # The killed worker's task went to another worker once its lease expired.
  local retried=0
  for name in $("${P[@]}" ps --format '{{.Names}}' | grep "^$PREFIX-worker-"); do
    retried=$((retried + $("${P[@]}" logs "$name" 2>&1 | grep -c "attempt 2: render views" || true)))
  done
  figure tasksRetriedAfterKill "$retried"
  [[ $retried -ge 1 ]] || die "no task was retried after $victim was killed: the kill hit no task"
  say "worker killed: the job finished, every output present once and identical"

  "${P[@]}" rm -f "$victim" >/dev/null
  start_worker 3 1000
  since=$(date -u +%Y-%m-%dT%H:%M:%S.%NZ)
  "$PF" --server "$ADDR" render "$SCENE" --cameras "$OUT/views.json" --chunk-frames 2 \
    >"$OUT/submit-restart.log" 2>&1 || { cat "$OUT/submit-restart.log" >&2; die "render submit failed"; }
  job=$(grep -o 'operations/[0-9a-f]*' "$OUT/submit-restart.log" | head -1 || true)
  [[ -n $job ]] || die "render submit printed no operation (see $OUT/submit-restart.log)"
  busy_worker "$since" >/dev/null
  "${P[@]}" restart -t 10 "$PREFIX-server" >/dev/null
  say "restarted the pf-server container while $job was running"
  wait_server "$ADDR" "$PREFIX-server" 30
  "$PF" --server "$ADDR" jobs wait "$job" --out "$OUT/run-server-restarted" \
    >"$OUT/run-server-restarted.log" 2>&1 ||
    { cat "$OUT/run-server-restarted.log" >&2; die "$job failed after the server restarted"; }
  same_outputs run-2-workers run-server-restarted
  say "server restarted: the job finished, every output present once and identical"
  "$PF" --server "$ADDR" jobs list >"$OUT/jobs.txt"
  cleanup_check
  trap - EXIT
}

# -- compose --------------------------------------------------------------------------
# postgres:15 cannot be pulled here: a stand-in built from Debian's
# PostgreSQL 15 that honours the three variables the compose file sets.
POSTGRES_IMAGE=localhost/pointforward/postgres-debian:15
postgres_image() {
  "${P[@]}" image exists "$POSTGRES_IMAGE" && return 0
  local dir
  dir=$(mktemp -d)
  cat >"$dir/entrypoint.sh" <<'SH'
#!/bin/sh
# POSTGRES_USER, POSTGRES_PASSWORD, POSTGRES_DB as the postgres image reads them.
set -e
PGDATA=/var/lib/postgresql/data
BIN=/usr/lib/postgresql/15/bin
if [ ! -s "$PGDATA/PG_VERSION" ]; then
  printf '%s\n' "$POSTGRES_PASSWORD" >/tmp/pw
  "$BIN/initdb" -D "$PGDATA" -U "$POSTGRES_USER" --pwfile=/tmp/pw --auth-host=scram-sha-256 >/dev/null
  rm /tmp/pw
  echo "host all all all scram-sha-256" >>"$PGDATA/pg_hba.conf"
  "$BIN/pg_ctl" -D "$PGDATA" -o "-c listen_addresses=''" -w start >/dev/null
  if [ "$POSTGRES_DB" != postgres ]; then
    psql -U "$POSTGRES_USER" -d postgres -c "CREATE DATABASE \"$POSTGRES_DB\"" >/dev/null
  fi
  "$BIN/pg_ctl" -D "$PGDATA" -m fast -w stop >/dev/null
fi
exec "$BIN/postgres" -D "$PGDATA" -c listen_addresses='*'
SH
  cat >"$dir/Containerfile" <<'DOCKERFILE'
FROM debian:bookworm
RUN apt-get update && apt-get install -y --no-install-recommends postgresql-15 \
 && rm -rf /var/lib/apt/lists/* \
 && mkdir -p /var/lib/postgresql/data /run/postgresql \
 && chown -R postgres:postgres /var/lib/postgresql /run/postgresql
COPY entrypoint.sh /usr/local/bin/entrypoint.sh
RUN chmod 755 /usr/local/bin/entrypoint.sh
USER postgres
ENTRYPOINT ["/usr/local/bin/entrypoint.sh"]
DOCKERFILE
  "${P[@]}" build --network host -t "$POSTGRES_IMAGE" "$dir" >"$OUT/build-postgres.log" 2>&1 ||
    die "building $POSTGRES_IMAGE failed; see $OUT/build-postgres.log"
  rm -rf "$dir"
}

# deploy/compose.yaml under docker-compose (Debian's 1.29) against podman's
# Docker-compatible API. Debian 12's podman-compose (1.0.3) cannot run it: it
# does not support a service's network aliases (`pf-server`).
COMPOSE_PROJECT=pfcompose
compose() {
  command -v docker-compose >/dev/null 2>&1 || die "docker-compose not found (apt-get install \
--no-install-recommends docker-compose); Debian 12's podman-compose 1.0.3 does not support the \
compose file's network aliases"
  for image in "$SERVER_IMAGE" "$WORKER_IMAGE"; do
    "${P[@]}" image exists "$image" || die "$image not built: run scripts/containers.sh build"
  done
  [[ -x $PF ]] || die "$PF not found: build it (make build) or pass --pf PATH"
  [[ -f $OUT/clip/clip.json && -f $OUT/views.json ]] || die "run the check step first: it makes the clip"
  postgres_image
  local sock=$OUT/podman.sock
  rm -f "$sock"
  "${P[@]}" system service --time=0 "unix://$sock" >"$OUT/podman-service.log" 2>&1 &
  SERVICE_PID=$!
  for _ in $(seq 100); do [[ -S $sock ]] && break; sleep 0.1; done
  export DOCKER_HOST=unix://$sock
  # The compose file as it is but for the top-level `name:`, which
  # docker-compose 1.29 predates (-p names the project); the override names
  # the stand-in for postgres:15 and the worker count.
  grep -v '^name:' deploy/compose.yaml >"$OUT/compose.yaml"
  local override=$OUT/compose.override.yaml
  write_override() {
    cat >"$override" <<YAML
services:
  postgres:
    image: $POSTGRES_IMAGE
  worker:
    deploy:
      replicas: $1
YAML
  }
  DC=(docker-compose -p "$COMPOSE_PROJECT" --project-directory "$ROOT/deploy" -f "$OUT/compose.yaml"
    -f "$override")
  write_override 2
  compose_down
  trap 'compose_down; stop_service' EXIT
  # Podman runs healthchecks from systemd timers; without systemd, the
  # script runs PostgreSQL's (servers start once it is healthy).
  (while :; do
    "${P[@]}" healthcheck run "${COMPOSE_PROJECT}_postgres_1" >/dev/null 2>&1 || true
    sleep 2
  done) &
  HEALTH_PID=$!
  local start
  start=$(now)
  timeout 600 "${DC[@]}" up -d --no-build >"$OUT/compose-up.log" 2>&1 ||
    { cat "$OUT/compose-up.log" >&2; die "docker-compose up failed"; }
  figure composeUpSeconds "$(elapsed "$start")"
  local addr=127.0.0.1:50051
  wait_server "$addr" "${COMPOSE_PROJECT}_server-a_1" 60
  wait_server 127.0.0.1:50052 "${COMPOSE_PROJECT}_server-b_1" 1
  start=$(now)
  "$PF" --server "$addr" render --clip "$OUT/clip/clip.json" --cameras "$OUT/views.json" \
    --out "$OUT/compose-2-workers" --chunk-frames 2 --wait >"$OUT/compose-2-workers.log" 2>&1 ||
    { cat "$OUT/compose-2-workers.log" >&2; die "compose: render --clip through server-a failed"; }
  figure composeReconstructAndRender2WorkersSeconds "$(elapsed "$start")"
  write_override 4
  timeout 600 "${DC[@]}" up -d --no-build >>"$OUT/compose-up.log" 2>&1 ||
    { cat "$OUT/compose-up.log" >&2; die "docker-compose up (4 workers) failed"; }
  local workers
  workers=$("${P[@]}" ps --format '{{.Names}}' | grep -c "^${COMPOSE_PROJECT}_worker_" || true)
  figure composeWorkers "$workers"
  [[ $workers -eq 4 ]] || die "compose: $workers worker containers running, expected 4"
  # server-b serves the same clip: one job store, one blob volume, so the
  # scene is a cache hit and only the render runs.
  start=$(now)
  "$PF" --server 127.0.0.1:50052 render --clip "$OUT/clip/clip.json" --cameras "$OUT/views.json" \
    --out "$OUT/compose-4-workers" --chunk-frames 2 --wait >"$OUT/compose-4-workers.log" 2>&1 ||
    { cat "$OUT/compose-4-workers.log" >&2; die "compose: render --clip through server-b failed"; }
  figure composeRender4WorkersSeconds "$(elapsed "$start")"
  same_outputs compose-2-workers compose-4-workers
  say "compose: PostgreSQL, 2 servers, 2 then 4 workers; the render through server-b (a cache hit) identical"
  compose_down
  stop_service
  trap - EXIT
}

DC=()
SERVICE_PID=
HEALTH_PID=
compose_down() {
  if [[ ${#DC[@]} -gt 0 ]]; then
    timeout 300 "${DC[@]}" down -v >"$OUT/compose-down.log" 2>&1 || true
  fi
  # What a restart loop left behind.
  local left
  left=$("${P[@]}" ps -aq --filter "label=com.docker.compose.project=$COMPOSE_PROJECT")
  [[ -z $left ]] || "${P[@]}" rm -f -t 2 $left >/dev/null 2>&1 || true
  "${P[@]}" network rm -f "${COMPOSE_PROJECT}_default" >/dev/null 2>&1 || true
  "${P[@]}" volume rm -f "${COMPOSE_PROJECT}_pgdata" "${COMPOSE_PROJECT}_blobs" >/dev/null 2>&1 || true
  if [[ -n $HEALTH_PID ]]; then kill "$HEALTH_PID" 2>/dev/null || true; HEALTH_PID=; fi
}
stop_service() {
  if [[ -n $SERVICE_PID ]]; then kill "$SERVICE_PID" 2>/dev/null || true; SERVICE_PID=; fi
}

for step in "${STEPS[@]}"; do
  case "$step" in
    build) build_images ;;
    check) check ;;
    compose) compose ;;
  esac
done
write_figures
say "every step passed (${STEPS[*]}); figures in $OUT/figures.json"
