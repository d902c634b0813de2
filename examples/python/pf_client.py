#!/usr/bin/python3
"""A small PointForward client in Python: reconstruct a clip, render views,
read an EXR back.

It talks to pf-server with the stubs the build generates from our protos
(build/python; put it on PYTHONPATH) and Debian's python3-grpcio,
python3-protobuf and python3-openimageio:

    PYTHONPATH=build/python /usr/bin/python3 examples/python/pf_client.py \
        --server 127.0.0.1:50051 --clip demo-out/clip/clip.json \
        --views demo-out/views.json --out /tmp/renders [--lidar]

Steps: check grpc.health.v1, list the services by server reflection, upload the clip's manifest and every file it
references to BlobService (only those the server lacks), CreateScene and
wait on the operation, CreateRenderJob and wait, download every output
(checking its SHA-256), and open the first EXR with OpenImageIO. The last
line printed is a JSON summary.

With --lidar the render job also renders a LiDAR sweep (views.lidars): 32
beams from -25 to 10 degrees, 0.5-degree columns, at the pose and time of
the clip's first recorded sweep. Its range image (<name>.range.exr:
channels range, hit, intensity) is read back and summarised.

With authentication on (pf-server --auth-token-file), give the token with
--token or PF_TOKEN: every call carries "authorization: Bearer <token>". With
TLS on, --tls-ca names the CA that signed the server's certificate.
"""

import argparse
import hashlib
import json
import os
import sys
import time

import grpc
from google.longrunning import operations_pb2, operations_pb2_grpc
from google.protobuf import duration_pb2, json_format
from pointforward.v1 import (blobs_pb2, blobs_pb2_grpc, resources_pb2, service_pb2,
                             service_pb2_grpc, views_pb2)

CHUNK = 1 << 20


class BearerToken(grpc.UnaryUnaryClientInterceptor, grpc.UnaryStreamClientInterceptor,
                  grpc.StreamUnaryClientInterceptor, grpc.StreamStreamClientInterceptor):
    """Adds "authorization: Bearer <token>" to every call's metadata."""

    def __init__(self, token):
        self._header = ("authorization", f"Bearer {token}")

    def _with_token(self, details):
        metadata = list(details.metadata or []) + [self._header]
        return details._replace(metadata=metadata) if hasattr(details, "_replace") else \
            _CallDetails(details.method, details.timeout, metadata, details.credentials,
                         details.wait_for_ready, details.compression)

    def intercept_unary_unary(self, continuation, details, request):
        return continuation(self._with_token(details), request)

    def intercept_unary_stream(self, continuation, details, request):
        return continuation(self._with_token(details), request)

    def intercept_stream_unary(self, continuation, details, requests):
        return continuation(self._with_token(details), requests)

    def intercept_stream_stream(self, continuation, details, requests):
        return continuation(self._with_token(details), requests)


class _CallDetails(grpc.ClientCallDetails):
    def __init__(self, method, timeout, metadata, credentials, wait_for_ready, compression):
        self.method = method
        self.timeout = timeout
        self.metadata = metadata
        self.credentials = credentials
        self.wait_for_ready = wait_for_ready
        self.compression = compression


def open_channel(server, tls_ca, token):
    """A channel to `server`: TLS when `tls_ca` names a CA file, the token on every call."""
    if tls_ca:
        with open(tls_ca, "rb") as f:
            channel = grpc.secure_channel(server, grpc.ssl_channel_credentials(f.read()))
    else:
        channel = grpc.insecure_channel(server)
    return grpc.intercept_channel(channel, BearerToken(token)) if token else channel


def health(channel):
    """grpc.health.v1.Health/Check on the whole server; True when SERVING."""
    check = channel.unary_unary("/grpc.health.v1.Health/Check",
                                request_serializer=lambda b: b,
                                response_deserializer=lambda b: b)
    return check(b"", timeout=5) == b"\x08\x01"  # status: SERVING


def _fields(data):
    """Yields (field number, value) of a protobuf message's length-delimited
    fields; enough to read reflection answers without their .proto."""
    i = 0
    while i < len(data):
        key, i = _varint(data, i)
        wire = key & 7
        if wire == 0:
            _, i = _varint(data, i)
        elif wire == 2:
            size, i = _varint(data, i)
            yield key >> 3, data[i:i + size]
            i += size
        else:
            raise ValueError(f"unexpected wire type {wire}")


def _varint(data, i):
    value, shift = 0, 0
    while True:
        byte = data[i]
        i += 1
        value |= (byte & 0x7F) << shift
        shift += 7
        if byte < 0x80:
            return value, i


def reflection_services(channel):
    """The services the server lists through gRPC server reflection
    (grpc.reflection.v1alpha; grpcurl and friends use the same)."""
    call = channel.stream_stream("/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo",
                                 request_serializer=lambda b: b,
                                 response_deserializer=lambda b: b)
    # ServerReflectionRequest{list_services: ""}: field 7, length 0.
    names = []
    for response in call(iter([b"\x3a\x00"]), timeout=5):
        for number, body in _fields(response):
            if number == 6:  # list_services_response
                for _, service in _fields(body):  # repeated ServiceResponse service = 1
                    names += [name.decode() for n, name in _fields(service) if n == 1]
    return sorted(names)


def digest_of(data):
    return resources_pb2.Digest(sha256=hashlib.sha256(data).hexdigest(), size_bytes=len(data))


def upload(blobs, contents):
    """Uploads {name: bytes}; returns {name: Digest}. Skips blobs the server has."""
    digests = {name: digest_of(data) for name, data in contents.items()}
    missing = blobs.FindMissingBlobs(
        blobs_pb2.FindMissingBlobsRequest(digests=list(digests.values()))).missing
    missing = {d.sha256 for d in missing}
    for name, data in contents.items():
        digest = digests[name]
        if digest.sha256 not in missing:
            continue

        def chunks(digest=digest, data=data):
            yield blobs_pb2.WriteBlobRequest(digest=digest, data=data[:CHUNK])
            for offset in range(CHUNK, len(data), CHUNK):
                yield blobs_pb2.WriteBlobRequest(data=data[offset:offset + CHUNK])

        blobs.WriteBlob(chunks())
        missing.discard(digest.sha256)
    return digests


def download(blobs, digest, path):
    """Streams a blob to `path`, checking its hash before the file appears."""
    hasher = hashlib.sha256()
    tmp = path + ".part"
    with open(tmp, "wb") as out:
        for chunk in blobs.ReadBlob(blobs_pb2.ReadBlobRequest(sha256=digest.sha256)):
            hasher.update(chunk.data)
            out.write(chunk.data)
    if hasher.hexdigest() != digest.sha256:
        os.remove(tmp)
        raise RuntimeError(f"{path}: content hashes to {hasher.hexdigest()}, not {digest.sha256}")
    os.replace(tmp, path)


def referenced_files(clip):
    """Paths a clip manifest references, as written in it."""
    paths = []
    for frame in clip.get("frames", []):
        paths += [frame[key] for key in ("image", "depth") if frame.get(key)]
    paths += [sweep["points"] for sweep in clip.get("lidar", []) if sweep.get("points")]
    return sorted(set(paths))


def wait(operations, operation, what):
    """Waits on an operation, printing its progress; returns it when done."""
    while not operation.done:
        operation = operations.WaitOperation(operations_pb2.WaitOperationRequest(
            name=operation.name, timeout=duration_pb2.Duration(seconds=1)))
        metadata = resources_pb2.OperationMetadata()
        operation.metadata.Unpack(metadata)
        print(f"{what}: {metadata.state} {metadata.stage} {metadata.fraction:.0%}", file=sys.stderr)
    if operation.HasField("error"):
        raise RuntimeError(f"{what} failed: {operation.error.message}")
    return operation


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--server", required=True, help="pf-server address, HOST:PORT")
    parser.add_argument("--clip", required=True, help="clip manifest (clip.json)")
    parser.add_argument("--views", required=True, help="RenderViews JSON (as for pf render)")
    parser.add_argument("--out", required=True, help="directory for the downloaded outputs")
    parser.add_argument("--lidar", action="store_true",
                        help="also render a LiDAR sweep at the clip's first recorded sweep")
    parser.add_argument("--token", default=os.environ.get("PF_TOKEN", ""),
                        help="bearer token (default: $PF_TOKEN; none: authentication off)")
    parser.add_argument("--tls-ca", default=os.environ.get("PF_TLS_CA", ""),
                        help="CA of the server's certificate: connect with TLS (default $PF_TLS_CA)")
    args = parser.parse_args()

    channel = open_channel(args.server, args.tls_ca, args.token.strip())
    if not health(channel):
        sys.exit(f"pf_client: {args.server} is not SERVING")
    services = reflection_services(channel)
    blobs = blobs_pb2_grpc.BlobServiceStub(channel)
    scenes = service_pb2_grpc.SceneServiceStub(channel)
    renders = service_pb2_grpc.RenderServiceStub(channel)
    operations = operations_pb2_grpc.OperationsStub(channel)

    # 1. Upload the clip and reconstruct it (or find it in the cache).
    clip_dir = os.path.dirname(os.path.abspath(args.clip))
    with open(args.clip, "rb") as f:
        manifest = f.read()
    files = {}
    for path in referenced_files(json.loads(manifest)):
        with open(os.path.join(clip_dir, path), "rb") as f:
            files[path] = f.read()
    digests = upload(blobs, {"clip.json": manifest, **files})
    uploaded = resources_pb2.UploadedClip(manifest=digests["clip.json"])
    for path in files:
        uploaded.files[path].CopyFrom(digests[path])
    started = time.time()
    operation = scenes.CreateScene(service_pb2.CreateSceneRequest(
        clip=resources_pb2.ClipSource(uploaded=uploaded)))
    operation = wait(operations, operation, "reconstruct")
    scene = resources_pb2.Scene()
    operation.response.Unpack(scene)
    print(f"{scene.name}: {scene.gaussians} gaussians in {time.time() - started:.1f} s",
          file=sys.stderr)

    # 2. Render the views and download every output.
    views = views_pb2.RenderViews()
    with open(args.views) as f:
        json_format.Parse(f.read(), views)
    if args.lidar:
        recorded = json.loads(manifest).get("lidar", [])
        if not recorded:
            sys.exit(f"pf_client: --lidar: {args.clip} records no LiDAR sweep to take a pose from")
        sweep = views.lidars.add(name="sweep", timestamp_us=int(recorded[0]["timestampUs"]))
        sweep.spec.beam_elevations_deg.extend(-25 + 35 * b / 31 for b in range(32))
        sweep.spec.azimuth_resolution_deg = 0.5
        sweep.world_from_sensor.extend(recorded[0]["worldFromSensor"])
    operation = renders.CreateRenderJob(service_pb2.CreateRenderJobRequest(
        scene=scene.name, views=views))
    operation = wait(operations, operation, "render")
    job = resources_pb2.RenderJob()
    operation.response.Unpack(job)
    os.makedirs(args.out, exist_ok=True)
    for output in job.files:
        download(blobs, output.digest, os.path.join(args.out, os.path.basename(output.name)))

    # 3. Read the first EXR back.
    import OpenImageIO as oiio
    exr_name = next(f.name for f in job.files if f.name.endswith(".exr"))
    image = oiio.ImageBuf(os.path.join(args.out, exr_name))
    spec = image.spec()
    stats = oiio.ImageBufAlgo.computePixelStats(image)
    channels = list(spec.channelnames)
    mean_rgb = [stats.avg[channels.index(c)] for c in ("R", "G", "B")]
    summary = {"scene": scene.name, "gaussians": scene.gaussians,
               "renderJob": job.name, "files": len(job.files), "exr": exr_name,
               "width": spec.width, "height": spec.height, "channels": channels,
               "meanRgb": mean_rgb, "services": services}

    # 4. The LiDAR sweeps: beams x columns range images, range in metres
    # and the scene's LiDAR intensity where hit is 1.
    if len(views.lidars):
        summary["lidars"] = []
        for lidar in views.lidars:
            image = oiio.ImageBuf(os.path.join(args.out, f"{lidar.name}.range.exr"))
            names = list(image.spec().channelnames)
            pixels = image.get_pixels(oiio.FLOAT)
            hits = pixels[:, :, names.index("hit")] > 0.5
            ranges = sorted(pixels[:, :, names.index("range")][hits].tolist())
            intensities = sorted(pixels[:, :, names.index("intensity")][hits].tolist())
            summary["lidars"].append({
                "name": lidar.name, "view": json_format.MessageToDict(lidar),
                "beams": image.spec().height, "columns": image.spec().width,
                "returns": len(ranges),
                "medianRangeM": ranges[len(ranges) // 2] if ranges else None,
                "medianIntensity": intensities[len(intensities) // 2] if ranges else None})
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
