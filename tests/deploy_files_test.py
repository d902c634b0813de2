#!/usr/bin/python3
"""Checks of the deployment files (issue #7) that need no Docker engine and no
cluster: yamllint, kustomize resolution and the structure of what each overlay
renders, the compose file, the Dockerfiles' build steps against the README's
install step and the Makefile's commands, the runtime packages against the
libraries the built binaries load, and docs/DEPLOY.md's settings table against
the programs' --help.

Run by ctest (tests/CMakeLists.txt), one ctest per TestCase class:
  deploy_files_test.py --source-dir DIR --bin-dir DIR [unittest arguments]
Needs Debian's python3-yaml and yamllint (scripts/install-deps.sh).
"""
import argparse
import copy
import math
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import unittest
import urllib.error
import urllib.request

import yaml

SOURCE_DIR = ""
BIN_DIR = ""
# Whether BIN_DIR's binaries are linked as the Dockerfile builds them (GCC,
# no sanitizers); a clang sanitizer tree links more libraries directly.
BINARIES_AS_DOCKERFILE = True

NAMESPACE = "pointforward"
OVERLAYS = ("cpu", "gpu")


def src(*parts):
    return os.path.join(SOURCE_DIR, *parts)


def read(*parts):
    with open(src(*parts), encoding="utf-8") as f:
        return f.read()


def load_yaml_documents(path):
    with open(path, encoding="utf-8") as f:
        return [doc for doc in yaml.safe_load_all(f) if doc is not None]


# -- docs/DEPLOY.md's settings table ----------------------------------------------


def settings_table():
    """Rows of the Configuration table: dicts program, flag, env, default."""
    text = read("docs", "DEPLOY.md")
    section = text.split("\n## Configuration\n", 1)
    if len(section) != 2:
        raise AssertionError("docs/DEPLOY.md: no '## Configuration' section")
    rows = []
    for line in section[1].splitlines():
        if line.startswith("## "):
            break
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 5 or cells[0] not in ("pf-server", "pf-worker"):
            continue
        flag = re.match(r"`(--[a-z][a-z-]*)", cells[1])
        if not flag:
            raise AssertionError(f"docs/DEPLOY.md: flag cell '{cells[1]}' does not start with `--name")
        env = cells[2].strip("`")
        default = cells[3]
        rows.append({
            "program": cells[0],
            "flag": flag.group(1),
            "env": None if env == "—" else env,
            # A backquoted default is a literal the --help text must show.
            "default": default.strip("`") if default.startswith("`") else None,
        })
    return rows


def help_flags(help_text):
    return set(re.findall(r"^\s{2}(--[a-z][a-z-]*)", help_text, re.MULTILINE)) - {"--help"}


def help_entry(help_text, flag):
    """The lines of --help that describe `flag`: from its line to the next flag's."""
    found = re.search(r"^\s{2}" + re.escape(flag) + r"\b(.*?)(?=^\s{2}--|\Z)", help_text, re.MULTILINE | re.DOTALL)
    if not found:
        raise AssertionError(f"{flag}: not in --help")
    return found.group(1)


def run_help(binary):
    result = subprocess.run([binary, "--help"], capture_output=True, text=True, timeout=30)
    if result.returncode != 0:
        raise AssertionError(f"{binary} --help: exit {result.returncode}: {result.stderr}")
    return result.stdout


# -- A small kustomize --------------------------------------------------------------


def strategic_merge(base, patch):
    """Merges `patch` into `base` as kubectl's strategic merge does for the
    fields used here: maps merge key by key, lists of maps with a `name`
    merge item by item on it, any other list is replaced whole."""
    for key, value in patch.items():
        if isinstance(value, dict) and isinstance(base.get(key), dict):
            strategic_merge(base[key], value)
        elif (isinstance(value, list) and isinstance(base.get(key), list) and value
              and all(isinstance(item, dict) and "name" in item for item in value)
              and all(isinstance(item, dict) and "name" in item for item in base[key])):
            by_name = {item["name"]: item for item in base[key]}
            for item in value:
                if item["name"] in by_name:
                    strategic_merge(by_name[item["name"]], item)
                else:
                    base[key].append(copy.deepcopy(item))
        else:
            base[key] = copy.deepcopy(value)


def pod_containers(obj):
    spec = obj.get("spec", {}).get("template", {}).get("spec", {})
    return spec.get("containers", []) + spec.get("initContainers", [])


def kustomization_path(directory):
    path = os.path.join(directory, "kustomization.yaml")
    if not os.path.isfile(path):
        raise AssertionError(f"{directory}: no kustomization.yaml")
    return path


def kustomize(directory):
    """Renders the kustomization in `directory`: resources (files and
    directories), patches (strategic merge, matched on kind and name),
    images, labels and namespace."""
    (k,) = load_yaml_documents(kustomization_path(directory))
    objects = []
    for resource in k.get("resources", []):
        path = os.path.normpath(os.path.join(directory, resource))
        objects += kustomize(path) if os.path.isdir(path) else load_yaml_documents(path)
    for patch in k.get("patches", []):
        for doc in load_yaml_documents(os.path.join(directory, patch["path"])):
            targets = [o for o in objects if o["kind"] == doc["kind"]
                       and o["metadata"]["name"] == doc["metadata"]["name"]]
            if len(targets) != 1:
                raise AssertionError(f"{directory}: patch {patch['path']} matches {len(targets)} objects")
            strategic_merge(targets[0], doc)
    for image in k.get("images", []):
        for obj in objects:
            for container in pod_containers(obj):
                name, _, tag = container["image"].partition(":")
                if name == image["name"]:
                    container["image"] = f"{image.get('newName', name)}:{image.get('newTag', tag)}"
    for labels in k.get("labels", []):
        for obj in objects:
            obj["metadata"].setdefault("labels", {}).update(labels["pairs"])
    if "namespace" in k:
        for obj in objects:
            if obj["kind"] != "Namespace":
                obj["metadata"]["namespace"] = k["namespace"]
    return objects


def kubectl_with_modern_kustomize():
    """Path of a kubectl whose kustomize is 4.2 or later (patches:, labels:),
    else None."""
    kubectl = shutil.which("kubectl")
    if not kubectl:
        return None
    result = subprocess.run([kubectl, "version", "--client"], capture_output=True, text=True, timeout=60)
    found = re.search(r"Kustomize Version: v(\d+)\.(\d+)", result.stdout)
    if not found or (int(found.group(1)), int(found.group(2))) < (4, 2):
        return None
    return kubectl


# -- Checks on one rendered overlay ---------------------------------------------------


class RenderedOverlay:
    def __init__(self, test, overlay, objects):
        self.test = test
        self.overlay = overlay
        self.objects = {(o["kind"], o["metadata"]["name"]): o for o in objects}
        test.assertEqual(len(self.objects), len(objects), f"{overlay}: duplicate kind/name")

    def get(self, kind, name):
        obj = self.objects.get((kind, name))
        self.test.assertIsNotNone(obj, f"overlay {self.overlay}: no {kind} {name}")
        return obj

    def container(self, kind, name):
        containers = pod_containers(self.get(kind, name))
        self.test.assertEqual(len(containers), 1, f"{kind} {name}: expected one container")
        return containers[0]


def keyed_by_name(value):
    """`value` with every list of named maps turned into a map by name, so
    two renderings compare equal whatever order their merges left."""
    if isinstance(value, dict):
        return {k: keyed_by_name(v) for k, v in value.items()}
    if isinstance(value, list) and value and all(isinstance(i, dict) and "name" in i for i in value):
        return {i["name"]: keyed_by_name(i) for i in value}
    if isinstance(value, list):
        return [keyed_by_name(i) for i in value]
    return value


def check_overlay(test, overlay, objects, worker_flags):
    r = RenderedOverlay(test, overlay, objects)
    test.assertIn(("Namespace", NAMESPACE), r.objects)
    for (kind, name), obj in r.objects.items():
        if kind != "Namespace":
            test.assertEqual(obj["metadata"].get("namespace"), NAMESPACE, f"{kind} {name}: namespace")

    # Every pod template's labels select it.
    for (kind, name), obj in r.objects.items():
        if kind in ("Deployment", "StatefulSet"):
            selector = obj["spec"]["selector"]["matchLabels"]
            labels = obj["spec"]["template"]["metadata"]["labels"]
            test.assertLessEqual(selector.items(), labels.items(), f"{kind} {name}: selector")

    # The Secret holds the keys the pods and the scaler read.
    secret = r.get("Secret", "pf-postgres")["stringData"]
    for key in ("POSTGRES_USER", "POSTGRES_PASSWORD", "POSTGRES_DB", "PF_STORE"):
        test.assertIn(key, secret)
    store = re.fullmatch(r"postgresql://([^:@/]+):([^@/]+)@([^:/]+):(\d+)/(\w+)", secret["PF_STORE"])
    test.assertIsNotNone(store, f"PF_STORE '{secret['PF_STORE']}' is not postgresql://USER:PASS@HOST:PORT/DB")
    test.assertEqual(store.group(1), secret["POSTGRES_USER"])
    test.assertEqual(store.group(2), secret["POSTGRES_PASSWORD"])
    test.assertEqual(store.group(5), secret["POSTGRES_DB"])
    # The full name: KEDA's operator resolves it from its own namespace.
    test.assertEqual(store.group(3), f"pf-postgres.{NAMESPACE}.svc.cluster.local")
    pg_service = r.get("Service", "pf-postgres")
    test.assertIn(int(store.group(4)), [p["port"] for p in pg_service["spec"]["ports"]])
    pg = r.get("StatefulSet", "pf-postgres")
    test.assertLessEqual(pg_service["spec"]["selector"].items(),
                         pg["spec"]["template"]["metadata"]["labels"].items())
    test.assertTrue(r.container("StatefulSet", "pf-postgres")["image"].startswith("postgres:15"))

    blobs = r.get("PersistentVolumeClaim", "pf-blobs")
    test.assertEqual(blobs["spec"]["accessModes"], ["ReadWriteMany"])

    # pf-server: 2 replicas, gRPC probes, resources, the store from the Secret,
    # the shared blob volume.
    server = r.get("Deployment", "pf-server")
    test.assertEqual(server["spec"]["replicas"], 2)
    test.assertEqual(server["spec"]["template"]["spec"]["securityContext"]["runAsUser"], 10001)
    c = r.container("Deployment", "pf-server")
    test.assertRegex(c["image"], r"^pointforward/pf-server:\w+")
    for probe in ("readinessProbe", "livenessProbe"):
        test.assertEqual(c[probe]["grpc"]["port"], 50051, f"pf-server {probe}")
    for part in ("requests", "limits"):
        test.assertIn("memory", c["resources"][part], f"pf-server resources.{part}")
    test.assertIn("cpu", c["resources"]["requests"])
    test.assertEqual({p["containerPort"] for p in c["ports"]}, {50051, 9090})
    env = {e["name"]: e for e in c["env"]}
    test.assertEqual(env["PF_STORE"]["valueFrom"]["secretKeyRef"], {"name": "pf-postgres", "key": "PF_STORE"})
    blob_mounts = [m for m in c["volumeMounts"] if m["mountPath"] == env["PF_BLOBS"]["value"]]
    test.assertEqual(len(blob_mounts), 1, "PF_BLOBS is not a mounted volume")
    volumes = {v["name"]: v for v in server["spec"]["template"]["spec"]["volumes"]}
    test.assertEqual(volumes[blob_mounts[0]["name"]]["persistentVolumeClaim"]["claimName"], "pf-blobs")

    service = r.get("Service", "pf-server")
    test.assertEqual({p["port"] for p in service["spec"]["ports"]}, {50051, 9090})
    test.assertLessEqual(service["spec"]["selector"].items(),
                         server["spec"]["template"]["metadata"]["labels"].items())

    # pf-worker: the overlay's image, device and resources; a grace period
    # long enough to finish a task; probes; flags that pf-worker has.
    worker = r.get("Deployment", "pf-worker")
    test.assertNotIn("replicas", worker["spec"], "KEDA owns the worker count; re-applying must not reset it")
    pod = worker["spec"]["template"]["spec"]
    test.assertGreaterEqual(pod["terminationGracePeriodSeconds"], 300)
    c = r.container("Deployment", "pf-worker")
    env = {e["name"]: e for e in c["env"]}
    test.assertEqual(env["PF_SERVER"]["value"], "pf-server:50051")
    test.assertIn("livenessProbe", c)
    test.assertEqual(c["livenessProbe"]["httpGet"]["path"], "/healthz")
    for word in c.get("args", []):
        if word.startswith("--"):
            test.assertIn(word, worker_flags, f"pf-worker args: {word} is not in docs/DEPLOY.md's table")
    test.assertEqual(env["PF_WORKER_ID"]["valueFrom"]["fieldRef"]["fieldPath"], "metadata.name")
    test.assertIn(env["PF_WORK_DIR"]["value"], [m["mountPath"] for m in c["volumeMounts"]])
    resources = c["resources"]
    for part in ("requests", "limits"):
        test.assertIn("memory", resources[part], f"pf-worker resources.{part}")
        test.assertIn("cpu", resources[part], f"pf-worker resources.{part}")
    cache = int(env["PF_CACHE_BYTES"]["value"])
    test.assertLess(cache, parse_quantity(resources["limits"]["memory"]), "scene cache above the memory limit")
    if overlay == "cpu":
        test.assertEqual(c["image"], "pointforward/pf-worker:dev")
        test.assertEqual(env["PF_DEVICE"]["value"], "cpu")
        test.assertNotIn("nvidia.com/gpu", resources["limits"])
    else:
        test.assertEqual(c["image"], "pointforward/pf-worker-gpu:dev")
        test.assertEqual(env["PF_DEVICE"]["value"], "cuda:0")
        test.assertEqual(int(resources["limits"]["nvidia.com/gpu"]), 1)
        test.assertEqual(pod["nodeSelector"], {"nvidia.com/gpu.present": "true"})
        test.assertIn("nvidia.com/gpu", [t["key"] for t in pod["tolerations"]])

    # Autoscaling: KEDA on the store's task table, to zero and back.
    scaled = r.get("ScaledObject", "pf-worker")["spec"]
    test.assertEqual(scaled["scaleTargetRef"]["name"], "pf-worker")
    test.assertEqual(scaled["minReplicaCount"], 0)
    test.assertEqual(scaled["maxReplicaCount"], 20 if overlay == "cpu" else 4)
    (trigger,) = scaled["triggers"]
    test.assertEqual(trigger["type"], "postgresql")
    auth = r.get("TriggerAuthentication", trigger["authenticationRef"]["name"])
    (ref,) = auth["spec"]["secretTargetRef"]
    test.assertEqual(ref["parameter"], "connection")
    test.assertIn(ref["key"], r.get("Secret", ref["name"])["stringData"])
    test.assertGreater(float(trigger["metadata"]["targetQueryValue"]), 0)
    return trigger["metadata"]["query"]


def parse_quantity(text):
    units = {"Ki": 2**10, "Mi": 2**20, "Gi": 2**30, "Ti": 2**40, "": 1}
    number, unit = re.fullmatch(r"(\d+)([KMGT]i|)", str(text)).groups()
    return int(number) * units[unit]


# -- The tests ----------------------------------------------------------------------


class YamllintTest(unittest.TestCase):
    def yamllint(self, target):
        if not shutil.which("yamllint"):
            self.fail("yamllint is not installed: run scripts/install-deps.sh")
        return subprocess.run(["yamllint", "-f", "parsable", "-c", src("deploy", ".yamllint"), target],
                              capture_output=True, text=True, timeout=120)

    def test_deploy_directory_passes(self):
        result = self.yamllint(src("deploy"))
        self.assertEqual(result.returncode, 0, result.stdout + result.stderr)

    def test_every_yaml_file_parses(self):
        count = 0
        for root, _, files in os.walk(src("deploy")):
            for name in files:
                if name.endswith((".yaml", ".yml")):
                    self.assertTrue(load_yaml_documents(os.path.join(root, name)), f"{name}: empty")
                    count += 1
        self.assertGreaterEqual(count, 15)

    def test_config_allows_missing_document_start_and_rejects_long_lines(self):
        with tempfile.TemporaryDirectory() as tmp:
            good = os.path.join(tmp, "good.yaml")
            with open(good, "w", encoding="utf-8") as f:
                f.write("key: " + "x" * 100 + "\n")
            self.assertEqual(self.yamllint(good).returncode, 0)
            bad = os.path.join(tmp, "bad.yaml")
            with open(bad, "w", encoding="utf-8") as f:
                f.write("key: " + "x" * 120 + "\n")
            result = self.yamllint(bad)
            self.assertNotEqual(result.returncode, 0)
            self.assertIn("line too long (125 > 120 characters)", result.stdout)


class KustomizeTest(unittest.TestCase):
    def worker_flags(self):
        return {row["flag"] for row in settings_table() if row["program"] == "pf-worker"}

    def test_kustomizations_name_existing_files(self):
        found = 0
        for root, _, files in os.walk(src("deploy", "k8s")):
            if "kustomization.yaml" not in files:
                continue
            found += 1
            (k,) = load_yaml_documents(os.path.join(root, "kustomization.yaml"))
            self.assertEqual(k["kind"], "Kustomization")
            for resource in k.get("resources", []):
                path = os.path.normpath(os.path.join(root, resource))
                if os.path.isdir(path):
                    self.assertTrue(os.path.isfile(os.path.join(path, "kustomization.yaml")),
                                    f"{root}: base {resource} has no kustomization.yaml")
                else:
                    self.assertTrue(os.path.isfile(path), f"{root}: resource {resource} does not exist")
            for patch in k.get("patches", []):
                self.assertTrue(os.path.isfile(os.path.join(root, patch["path"])),
                                f"{root}: patch {patch['path']} does not exist")
            # Every YAML file beside it is used (no forgotten manifest).
            named = set(k.get("resources", [])) | {p["path"] for p in k.get("patches", [])}
            for name in files:
                if name.endswith(".yaml") and name != "kustomization.yaml":
                    self.assertIn(name, named, f"{root}/{name} is not in its kustomization.yaml")
        self.assertEqual(found, 3)
        for overlay in OVERLAYS:
            (k,) = load_yaml_documents(src("deploy", "k8s", "overlays", overlay, "kustomization.yaml"))
            self.assertIn("../../base", k["resources"])

    def test_overlays_render_with_own_resolver(self):
        for overlay in OVERLAYS:
            with self.subTest(overlay=overlay):
                objects = kustomize(src("deploy", "k8s", "overlays", overlay))
                check_overlay(self, overlay, objects, self.worker_flags())

    def test_overlays_render_with_kubectl(self):
        kubectl = kubectl_with_modern_kustomize()
        if not kubectl:
            self.skipTest("no kubectl with kustomize >= 4.2 (Debian 12's kubernetes-client is 1.20); "
                          "the own resolver's test covers the overlays")
        for overlay in OVERLAYS:
            with self.subTest(overlay=overlay):
                result = subprocess.run([kubectl, "kustomize", src("deploy", "k8s", "overlays", overlay)],
                                        capture_output=True, text=True, timeout=120)
                self.assertEqual(result.returncode, 0, result.stderr)
                objects = [d for d in yaml.safe_load_all(result.stdout) if d is not None]
                check_overlay(self, overlay, objects, self.worker_flags())
                # Same objects as the own resolver, and the same pod specs.
                own = {(o["kind"], o["metadata"]["name"]): o for o in kustomize(
                    src("deploy", "k8s", "overlays", overlay))}
                theirs = {(o["kind"], o["metadata"]["name"]): o for o in objects}
                self.assertEqual(set(own), set(theirs))
                for key in (("Deployment", "pf-server"), ("Deployment", "pf-worker")):
                    self.assertEqual(keyed_by_name(own[key]["spec"]["template"]),
                                     keyed_by_name(theirs[key]["spec"]["template"]), key)

    def test_scaler_query_matches_store_schema(self):
        objects = kustomize(src("deploy", "k8s", "base"))
        (scaled,) = [o for o in objects if o["kind"] == "ScaledObject"]
        query = scaled["spec"]["triggers"][0]["metadata"]["query"]
        parsed = re.fullmatch(r"SELECT COUNT\(\*\) FROM (\w+) WHERE (\w+) IN \(([^)]*)\)", query)
        self.assertIsNotNone(parsed, f"unexpected query shape: {query}")
        table, column, states = parsed.group(1), parsed.group(2), re.findall(r"'(\w+)'", parsed.group(3))
        self.assertEqual(sorted(states), ["LEASED", "QUEUED"])
        schema = read("server", "store", "sql_job_store.cc")
        create = re.search(r"CREATE TABLE " + table + r" \((.*?)\)\)sql", schema, re.DOTALL)
        self.assertIsNotNone(create, f"server/store/sql_job_store.cc: no table '{table}'")
        self.assertRegex(create.group(1), r"\b" + column + r" TEXT NOT NULL")
        names = read("server", "store", "job_store.cc")
        task_states = re.search(r"TaskStateName\(TaskState state\) \{(.*?)\n\}", names, re.DOTALL)
        self.assertIsNotNone(task_states, "server/store/job_store.cc: no TaskStateName")
        for state in states:
            self.assertIn(f'"{state}"', task_states.group(1))
        # pf_queue_depth (the store's CountQueuedTasks) is the QUEUED part of
        # the same count, as docs/DEPLOY.md says.
        self.assertRegex(schema, r"SELECT COUNT\(\*\) FROM " + table + r" WHERE " + column + r" = 'QUEUED'")

    def test_scaling_rule(self):
        # workers = ceil(outstanding / target), clamped: the rule of
        # docs/DEPLOY.md, computed as the HPA does from the ScaledObject.
        objects = kustomize(src("deploy", "k8s", "overlays", "gpu"))
        (scaled,) = [o["spec"] for o in objects if o["kind"] == "ScaledObject"]
        target = float(scaled["triggers"][0]["metadata"]["targetQueryValue"])

        def workers(outstanding):
            if outstanding <= float(scaled["triggers"][0]["metadata"]["activationTargetQueryValue"]):
                return scaled["minReplicaCount"]
            return min(scaled["maxReplicaCount"], max(1, math.ceil(outstanding / target)))

        self.assertEqual([workers(n) for n in (0, 1, 2, 3, 7, 100)], [0, 1, 1, 2, 4, 4])
        self.assertIn("workers = clamp(ceil(outstanding / 2), 0, maxReplicaCount)", read("docs", "DEPLOY.md"))


class ComposeTest(unittest.TestCase):
    def test_services(self):
        (compose,) = load_yaml_documents(src("deploy", "compose.yaml"))
        services = compose["services"]
        pg = services["postgres"]
        self.assertEqual(pg["image"], "postgres:15")
        self.assertIn("pg_isready", " ".join(pg["healthcheck"]["test"]))
        self.assertIn("pgdata:/var/lib/postgresql/data", pg["volumes"])

        servers = [s for s in services.values() if s.get("build", {}).get("target") == "server"]
        self.assertEqual(len(servers), 2)
        stores = {s["environment"]["PF_STORE"] for s in servers}
        self.assertEqual(len(stores), 1, "the two servers must share one store")
        self.assertRegex(stores.pop(), r"^postgresql://pf:[^@]+@postgres:5432/pf$")
        self.assertEqual({tuple(s["volumes"]) for s in servers}, {("blobs:/var/lib/pf/blobs",)})
        for s in servers:
            self.assertEqual(s["environment"]["PF_BLOBS"], "/var/lib/pf/blobs")
            self.assertEqual(s["depends_on"]["postgres"]["condition"], "service_healthy")
            self.assertIn("pf-server", s["networks"]["default"]["aliases"])
        published = [p.split(":")[0] for s in servers for p in s["ports"]]
        self.assertEqual(len(published), len(set(published)), "host ports collide")
        self.assertIn("blobs", compose["volumes"])
        self.assertIn("pgdata", compose["volumes"])

        worker = services["worker"]
        self.assertEqual(worker["build"]["target"], "worker")
        self.assertGreaterEqual(worker["deploy"]["replicas"], 2)
        self.assertEqual(worker["environment"]["PF_SERVER"], "pf-server:50051")
        self.assertNotIn("ports", worker, "replicated workers cannot publish a host port")
        self.assertEqual(worker["stop_grace_period"], "10m")
        self.assertEqual(worker["environment"]["PF_DEVICE"], "cpu")
        flags = {row["flag"] for row in settings_table() if row["program"] == "pf-worker"}
        for word in worker.get("command", []):
            if word.startswith("--"):
                self.assertIn(word, flags)

    def test_compose_schema(self):
        # Debian 12's docker-compose (1.29, not in install-deps.sh) validates
        # against the Compose schema offline; it predates the top-level
        # `name:`, which is left out of the copy it checks.
        compose = shutil.which("docker-compose")
        if not compose:
            self.skipTest("docker-compose is not installed; the structural checks cover the file")
        with tempfile.TemporaryDirectory() as tmp:
            copy_path = os.path.join(tmp, "compose.yaml")
            with open(copy_path, "w", encoding="utf-8") as f:
                f.write(re.sub(r"^name: .*\n", "", read("deploy", "compose.yaml"), flags=re.MULTILINE))
            result = subprocess.run(
                [compose, "--project-directory", src("deploy"), "-f", copy_path, "config", "--quiet"],
                capture_output=True, text=True, timeout=120)
        self.assertEqual(result.returncode, 0, result.stderr)

    def test_environment_variables_are_documented(self):
        documented = {row["env"] for row in settings_table() if row["env"]}
        # Environment variables; -DPF_... on a cmake line is a build option.
        variable = r"(?<!-D)\b(PF_[A-Z_]+)\b"
        used = set()
        for root, _, files in os.walk(src("deploy")):
            for name in files:
                if name.endswith(".yaml") or name.startswith("Dockerfile"):
                    with open(os.path.join(root, name), encoding="utf-8") as f:
                        used |= set(re.findall(variable, f.read()))
        used |= set(re.findall(variable, read("Dockerfile")))
        used -= {"PF_DB_PASSWORD"}  # compose's own interpolation variable
        self.assertTrue(used)
        self.assertLessEqual(used, documented, f"undocumented: {sorted(used - documented)}")


class DockerfileTest(unittest.TestCase):
    CONFIGURE = "cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release"
    BUILD = "ninja -C build pf pf-server pf-worker"

    @staticmethod
    def stages(text):
        """{stage name: (base image, text of its instructions)}, in order."""
        text = re.sub(r"\\\n", " ", text)
        result = {}
        name = None
        for line in text.splitlines():
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            found = re.match(r"FROM\s+(\S+)\s+AS\s+(\S+)", line, re.IGNORECASE)
            if found:
                name = found.group(2)
                result[name] = [found.group(1), ""]
            elif name:
                result[name][1] += line + "\n"
        return {k: tuple(v) for k, v in result.items()}

    def check_build_stage(self, path):
        stages = self.stages(read(path))
        base, body = stages["build"]
        self.assertEqual(base, "debian:bookworm", path)
        # The README's install step is scripts/install-deps.sh (via make).
        self.assertIn("scripts/install-deps.sh", read("README.md"))
        self.assertIn("@scripts/install-deps.sh", read("Makefile"))
        self.assertRegex(body, r"RUN scripts/install-deps.sh( |$)", path)
        self.assertLess(body.index("scripts/install-deps.sh"), body.index("COPY . ."), path)
        # The Makefile's configure line, with the build directory and type
        # filled in; the three programs.
        make_configure = re.search(r"@(cmake -S \. -B .*)>/dev/null", read("Makefile")).group(1).strip()
        expected = (make_configure.replace("$(BUILD_DIR)", "build").replace("$(BUILD_TYPE)", "Release")
                    .replace(" $(CMAKE_ARGS)", ""))
        self.assertEqual(expected, self.CONFIGURE)
        self.assertIn(self.CONFIGURE, body, path)
        self.assertIn(self.BUILD, body, path)
        for target, cmake in (("pf", "client"), ("pf-server", "server"), ("pf-worker", "worker")):
            self.assertRegex(read(cmake, "CMakeLists.txt"), r"add_executable\(" + re.escape(target) + r"\b")
        return stages

    def test_build_stage_is_the_readme_build(self):
        self.check_build_stage("Dockerfile")

    def test_gpu_build_stage_is_the_same(self):
        stages = self.check_build_stage(os.path.join("deploy", "gpu", "Dockerfile.gpu"))
        base, body = stages["worker"]
        self.assertEqual(base, "debian:bookworm-slim")
        self.assertIn("/opt/libtorch/lib", body)
        self.assertIn("NVIDIA_VISIBLE_DEVICES=all", body)
        self.assertIn('ENTRYPOINT ["pf-worker"]', body)
        # The CPU image's runtime libraries but Debian's LibTorch (the CUDA
        # one is in /opt/libtorch), plus the CUDA runtime.
        cpu_packages = self.runtime_packages(self.stages(read("Dockerfile"))["runtime"][1])
        self.assertTrue({"libtorch1.13", "libopenblas0-pthread"} <= cpu_packages)
        self.assertEqual(self.runtime_packages(body),
                         cpu_packages - {"libtorch1.13", "libopenblas0-pthread"} | {"cuda-cudart-${CUDA_PKG}"})

    def test_runtime_targets(self):
        text = read("Dockerfile")
        stages = self.stages(text)
        self.assertEqual(list(stages), ["build", "runtime", "worker", "server"])  # server is the default
        self.assertEqual(stages["runtime"][0], "debian:bookworm-slim")
        body = stages["runtime"][1]
        self.assertIn("useradd --uid 10001", body)
        self.assertIn("USER pf", body)
        self.assertIn("COPY --from=build /src/build/bin/pf /src/build/bin/pf-server /src/build/bin/pf-worker",
                      body)
        # pf import pandaset's pickle reader lies beside pf, where pf looks for
        # it (CMake copies it into build/bin).
        self.assertIn("COPY --from=build /src/build/bin/pf /src/build/bin/pf-server /src/build/bin/pf-worker "
                      "/usr/local/bin/", body)
        self.assertIn("COPY --from=build /src/build/bin/pandaset_pickles.py /usr/local/bin/", body)
        self.assertIn('configure_file(pandaset_pickles.py "${CMAKE_BINARY_DIR}/bin/pandaset_pickles.py" COPYONLY)',
                      read("engine", "importers", "CMakeLists.txt"))
        self.assertIn('kPandasetPicklesModule[] = "pandaset_pickles.py"',
                      read("engine", "importers", "pandaset_importer.h"))
        self.assertIn("python3-pandas", read("scripts", "install-deps.sh"))
        self.assertEqual(stages["server"][0], "runtime")
        self.assertEqual(stages["worker"][0], "runtime")
        self.assertIn('ENTRYPOINT ["pf-server"]', stages["server"][1])
        self.assertIn("EXPOSE 50051 9090", stages["server"][1])
        self.assertIn('ENTRYPOINT ["pf-worker"]', stages["worker"][1])
        self.assertIsNone(re.search(r"^HEALTHCHECK", text, re.MULTILINE))
        ignore = read(".dockerignore").split()
        for entry in (".git", "build", "build-*"):
            self.assertIn(entry, ignore)

    @staticmethod
    def runtime_packages(body):
        found = re.search(r"apt-get install -y --no-install-recommends (.*?) &&", body)
        return set(found.group(1).split())

    def test_runtime_packages_cover_the_binaries(self):
        packages = self.runtime_packages(self.stages(read("Dockerfile"))["runtime"][1])
        for package in packages:
            status = subprocess.run(["dpkg-query", "-W", "-f=${db:Status-Status}", package],
                                    capture_output=True, text=True)
            self.assertEqual(status.stdout, "installed", f"{package}: not a Debian 12 package installed here")
        if not BINARIES_AS_DOCKERFILE:
            self.skipTest(f"the binaries in {BIN_DIR} are not built as the Dockerfile builds them "
                          "(clang or sanitizers): their libraries are checked in the GCC tree")
        checked = 0
        for program in ("pf", "pf-server", "pf-worker"):
            binary = os.path.join(BIN_DIR, program)
            if not os.path.exists(binary):
                print(f"deploy_files_test: {binary} not built; its libraries are not checked", file=sys.stderr)
                continue
            checked += 1
            for library, package in self.needed_packages(binary).items():
                self.assertTrue(package == "libc6" or package in packages,
                                f"{program} needs {library} from {package}, missing in the Dockerfile")
        if checked == 0:
            self.skipTest(f"no binaries in {BIN_DIR}")

    @staticmethod
    def needed_packages(binary):
        """{soname: Debian package} of the binary's direct dependencies."""
        dynamic = subprocess.run(["readelf", "-d", binary], capture_output=True, text=True, check=True).stdout
        needed = re.findall(r"\(NEEDED\)\s+Shared library: \[(.*?)\]", dynamic)
        # The dynamic loader (named by programs that link the CUDA runtime
        # statically) is libc6's, and ldd lists it without a path.
        needed = [soname for soname in needed if not soname.startswith("ld-linux")]
        ldd = subprocess.run(["ldd", binary], capture_output=True, text=True, check=True).stdout
        paths = dict(re.findall(r"^\s*(\S+) => (\S+)", ldd, re.MULTILINE))
        resolved = {}
        for soname in needed:
            path = paths.get(soname)
            if path is None or path == "not":
                raise AssertionError(f"{binary}: {soname} does not resolve")
            resolved[soname] = (path, os.path.realpath(path))
        # One dpkg -S for every path (it is slow per call); a library may be
        # registered under its symlink's path or its real path.
        search = subprocess.run(["dpkg", "-S"] + sorted({p for pair in resolved.values() for p in pair}),
                                capture_output=True, text=True)
        owners = {}
        for line in search.stdout.splitlines():
            package, _, path = line.partition(": ")
            owners[path] = package.split(",")[0].split(":")[0]
        result = {}
        for soname, (path, real) in resolved.items():
            owner = owners.get(path) or owners.get(real)
            if owner is None:
                raise AssertionError(f"{binary}: {path} belongs to no Debian package")
            result[soname] = owner
        return result


class SettingsTableTest(unittest.TestCase):
    def check_program(self, program):
        binary = os.path.join(BIN_DIR, program)
        if not os.path.exists(binary):
            self.skipTest(f"{binary} is not built; its rows of docs/DEPLOY.md are not checked")
        help_text = run_help(binary)
        rows = [row for row in settings_table() if row["program"] == program]
        self.assertTrue(rows)
        flags = [row["flag"] for row in rows]
        self.assertEqual(len(flags), len(set(flags)), f"{program}: a flag is in the table twice")
        self.assertEqual(set(flags), help_flags(help_text),
                         f"{program}: table and --help differ")
        # The same environment variables; where --help names one in a flag's
        # entry (pf-server does; pf-worker lists them all in a paragraph), it
        # is that flag's row.
        self.assertEqual({row["env"] for row in rows if row["env"]},
                         set(re.findall(r"\b(PF_[A-Z_]+)\b", help_text)),
                         f"{program}: environment variables of the table and --help differ")
        for row in rows:
            entry = " ".join(help_entry(help_text, row["flag"]).split())
            named = re.findall(r"\b(PF_[A-Z_]+)\b", entry)
            if named:
                self.assertEqual(named, [row["env"]], f"{program} {row['flag']}: environment variable")
            if row["default"]:
                self.assertRegex(entry, r"default:? " + re.escape(row["default"]) + r"(?=[);,\s]|$)",
                                 f"{program} {row['flag']}: the table's default is not the --help one")

    def test_pf_server(self):
        self.check_program("pf-server")

    def test_pf_worker(self):
        self.check_program("pf-worker")

    def test_table_parser_sees_every_row(self):
        text = read("docs", "DEPLOY.md").split("\n## Configuration\n", 1)[1].split("\n## ", 1)[0]
        rows = [line for line in text.splitlines() if re.match(r"\| pf-(server|worker) \|", line)]
        self.assertEqual(len(settings_table()), len(rows))
        self.assertGreaterEqual(len(rows), 20)


class MetricsDocTest(unittest.TestCase):
    """docs/DEPLOY.md's metrics table names exactly the metrics the programs
    register (a metric added or renamed without its documentation fails)."""

    @staticmethod
    def documented():
        text = read("docs", "DEPLOY.md").split("\n## Metrics\n", 1)[1].split("\n## ", 1)[0]
        return set(re.findall(r"^\| `(pf_[a-z0-9_]+)", text, re.MULTILINE))

    @staticmethod
    def registered():
        names = set()
        for program in ("server", "worker"):
            for root, dirs, files in os.walk(src(program)):
                dirs[:] = [d for d in dirs if d != "engine"]
                for name in files:
                    if name.endswith(".cc") and not name.endswith("_test.cc"):
                        with open(os.path.join(root, name), encoding="utf-8") as f:
                            names |= set(re.findall(r"\b(?:Counter|Gauge|Histogram|CallbackGauge)\(\s*\"(pf_[a-z0-9_]+)\"",
                                                    f.read()))
        return names

    def test_every_metric_is_documented(self):
        registered = self.registered()
        self.assertTrue(registered, "no metric registration found in server/ or worker/")
        self.assertEqual(self.documented(), registered)

    def test_autoscaling_metric_is_documented_as_such(self):
        self.assertIn("pf_queue_depth", self.documented())
        self.assertIn("`pf_queue_depth` counts", read("docs", "DEPLOY.md"))


def free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def http_get(port, path):
    """(status, body) of GET http://127.0.0.1:port/path; status 0 when the
    port does not answer."""
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=5) as response:
            return response.status, response.read().decode()
    except urllib.error.HTTPError as error:
        return error.code, ""
    except OSError:
        return 0, ""


def grpc_health_check(port):
    """Status of grpc.health.v1.Health/Check for service "" (what a
    Kubernetes `grpc:` probe asks), as the raw enum value (1 = SERVING).
    The messages are encoded by hand: the request is empty, the response is
    field 1 (status) as a varint."""
    import grpc  # Debian's python3-grpcio; imported here so the other tests do not need it.
    with grpc.insecure_channel(f"127.0.0.1:{port}") as channel:
        check = channel.unary_unary("/grpc.health.v1.Health/Check",
                                    request_serializer=lambda _: b"", response_deserializer=lambda raw: raw)
        raw = check(None, timeout=5)
    if raw == b"":
        return 0  # UNKNOWN, the default value, is not encoded.
    if len(raw) != 2 or raw[0] != 0x08:
        raise AssertionError(f"unexpected HealthCheckResponse bytes {raw!r}")
    return raw[1]


def wait_until(predicate, seconds, what):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.1)
    raise AssertionError(f"timed out after {seconds} s waiting for {what}")


def container_environment(container, substitutions):
    """The container's env as a dict, each value taken from `substitutions`
    when named there (for secret and field references, and cluster
    addresses), else the manifest's literal value."""
    env = {}
    for entry in container.get("env", []):
        name = entry["name"]
        if name in substitutions:
            env[name] = substitutions[name]
        elif "value" in entry:
            env[name] = str(entry["value"])
        else:
            raise AssertionError(f"{container['name']}: env {name} has no value and no substitution")
    return env


class ManifestSmokeTest(unittest.TestCase):
    """Runs the real pf-server and pf-worker on loopback configured by the
    environment of the cpu overlay's containers (only addresses, paths and
    secrets substituted), and asks them what the overlay's probes ask: the
    server's gRPC health, the worker's GET /healthz on its metrics port. Then
    SIGTERM: both exit 0. The gpu overlay's worker settings are refused with
    a message naming --device, as docs/DEPLOY.md says, by a build whose
    LibTorch sees no GPU (Debian's is CPU-only)."""

    def setUp(self):
        for program in ("pf-server", "pf-worker"):
            if not os.path.exists(os.path.join(BIN_DIR, program)):
                self.skipTest(f"{os.path.join(BIN_DIR, program)} is not built")
        self.tmp = tempfile.mkdtemp(prefix="pf-deploy-smoke-")
        self.processes = []

    def tearDown(self):
        for process in self.processes:
            if process.poll() is None:
                process.kill()
                process.wait()
        shutil.rmtree(self.tmp, ignore_errors=True)

    def start(self, program, env, log_name):
        log = open(os.path.join(self.tmp, log_name), "w", encoding="utf-8")
        self.addCleanup(log.close)
        base = {k: v for k, v in os.environ.items() if not k.startswith("PF_")}
        process = subprocess.Popen([os.path.join(BIN_DIR, program)] + env.pop("__args__", []),
                                   env={**base, **env}, stdout=log, stderr=subprocess.STDOUT)
        self.processes.append(process)
        return process

    def log(self, name):
        with open(os.path.join(self.tmp, name), encoding="utf-8") as f:
            return f.read()

    def rendered(self, overlay):
        return {(o["kind"], o["metadata"]["name"]): o for o in kustomize(src("deploy", "k8s", "overlays", overlay))}

    def test_cpu_overlay_settings_run_and_answer_the_probes(self):
        objects = self.rendered("cpu")
        server_container = pod_containers(objects[("Deployment", "pf-server")])[0]
        worker_container = pod_containers(objects[("Deployment", "pf-worker")])[0]

        metrics_port = free_port()
        port_file = os.path.join(self.tmp, "port")
        server_env = container_environment(server_container, {
            "PF_LISTEN": "127.0.0.1:0",
            "PF_METRICS_LISTEN": f"127.0.0.1:{metrics_port}",
            "PF_STORE": "sqlite:" + os.path.join(self.tmp, "jobs.db"),
            "PF_BLOBS": os.path.join(self.tmp, "blobs"),
        })
        server_env["__args__"] = ["--port-file", port_file]
        server = self.start("pf-server", server_env, "server.log")
        wait_until(lambda: os.path.exists(port_file) or server.poll() is not None, 30, "pf-server's port file")
        self.assertIsNone(server.poll(), self.log("server.log"))
        with open(port_file, encoding="utf-8") as f:
            grpc_port = int(f.read())

        # The server's probes: gRPC health on the port the manifest probes
        # (50051 there, the bound port here), and its metrics.
        self.assertEqual(server_container["readinessProbe"]["grpc"]["port"], 50051)
        self.assertEqual(grpc_health_check(grpc_port), 1, "grpc.health.v1 is not SERVING")
        wait_until(lambda: http_get(metrics_port, "/metrics")[0] == 200, 10, "the server's /metrics")
        status, body = http_get(metrics_port, "/metrics")
        self.assertRegex(body, r'(?m)^pf_queue_depth\{kind="render"\} 0$')

        worker_metrics = free_port()
        worker_env = container_environment(worker_container, {
            "PF_SERVER": f"127.0.0.1:{grpc_port}",
            "PF_METRICS_LISTEN": f"127.0.0.1:{worker_metrics}",
            "PF_WORKER_ID": "pf-worker-smoke-0",
            "PF_WORK_DIR": os.path.join(self.tmp, "work"),
        })
        worker = self.start("pf-worker", worker_env, "worker.log")
        probe = worker_container["livenessProbe"]["httpGet"]
        self.assertEqual(probe["port"], "metrics")
        wait_until(lambda: http_get(worker_metrics, probe["path"])[0] == 200 or worker.poll() is not None, 30,
                   f"the worker's {probe['path']}")
        self.assertIsNone(worker.poll(), self.log("worker.log"))
        # One GET may fail while the worker's small HTTP server is busy (seen
        # once on a loaded machine); the metric must be there within 10 s.
        wait_until(lambda: re.search(r"(?m)^pf_scene_cache_bytes 0$",
                                     http_get(worker_metrics, "/metrics")[1]) is not None,
                   10, "pf_scene_cache_bytes 0 on the worker's /metrics")

        # Graceful shutdown: an idle worker and the server exit 0 on SIGTERM.
        for process, name, seconds in ((worker, "worker.log", 20), (server, "server.log", 20)):
            process.send_signal(signal.SIGTERM)
            try:
                code = process.wait(timeout=seconds)
            except subprocess.TimeoutExpired:
                self.fail(f"no exit {seconds} s after SIGTERM:\n{self.log(name)}")
            self.assertEqual(code, 0, self.log(name))
        self.assertIn("pf-worker-smoke-0", self.log("worker.log"))

    def test_gpu_overlay_device_is_refused_where_no_gpu_is_usable(self):
        # Our builds use Debian's CPU LibTorch (or none): cuda:0 cannot run.
        worker_container = pod_containers(self.rendered("gpu")[("Deployment", "pf-worker")])[0]
        env = container_environment(worker_container, {
            "PF_SERVER": "127.0.0.1:1",
            "PF_METRICS_LISTEN": f"127.0.0.1:{free_port()}",
            "PF_WORKER_ID": "pf-worker-gpu-0",
            "PF_WORK_DIR": os.path.join(self.tmp, "work"),
        })
        self.assertEqual(env["PF_DEVICE"], "cuda:0")
        worker = self.start("pf-worker", env, "gpu.log")
        self.assertEqual(worker.wait(timeout=20), 2)
        self.assertIn("--device: 'cuda:0' is not available", self.log("gpu.log"))


def main():
    global SOURCE_DIR, BIN_DIR, BINARIES_AS_DOCKERFILE
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source-dir", required=True)
    parser.add_argument("--bin-dir", required=True)
    parser.add_argument("--binaries-as-dockerfile", choices=("ON", "OFF"), default="ON")
    args, rest = parser.parse_known_args()
    SOURCE_DIR = os.path.abspath(args.source_dir)
    BIN_DIR = os.path.abspath(args.bin_dir)
    BINARIES_AS_DOCKERFILE = args.binaries_as_dockerfile == "ON"
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)


if __name__ == "__main__":
    main()
