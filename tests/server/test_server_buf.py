#!/usr/bin/env python3
"""buf curl (npm @bufbuild/buf, installed by scripts/setup.sh) against a real
horizond, through server reflection only: every service listed, every
service's methods listed (the health service's too), and calls of the
health check, GetDataset, LineOfSight and a streamed ComputeViewshed.
Exit 77 (ctest: skipped) when buf is not installed.
"""
import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from test_server_python import start_daemon  # noqa: E402


def call(buf, address, method, data):
    run = subprocess.run([buf, "curl", "--protocol", "grpc", "--http2-prior-knowledge", "-d", json.dumps(data),
                          "http://%s/%s" % (address, method)], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, "%s: exit %d\n%s%s" % (method, run.returncode, run.stdout, run.stderr)
    # A server stream prints one JSON document a message.
    decoder, text, out = json.JSONDecoder(), run.stdout.strip(), []
    while text:
        doc, end = decoder.raw_decode(text)
        out.append(doc)
        text = text[end:].strip()
    return out


def listing(buf, address, flag):
    run = subprocess.run([buf, "curl", "--protocol", "grpc", "--http2-prior-knowledge", flag, "http://" + address],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, "%s: exit %d\n%s%s" % (flag, run.returncode, run.stdout, run.stderr)
    return run.stdout.split()


def run_checks(buf, address):
    services = listing(buf, address, "--list-services")
    for s in ["grpc.health.v1.Health", "grpc.reflection.v1alpha.ServerReflection", "horizon.v1.DatasetService",
              "horizon.v1.VisibilityService", "horizon.v1.SessionService", "horizon.v1.TraceService",
              "horizon.v1.MeshService"]:
        assert s in services, (s, services)
    methods = listing(buf, address, "--list-methods")
    for m in ["grpc.health.v1.Health/Check", "grpc.health.v1.Health/Watch",
              "grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo",
              "horizon.v1.DatasetService/GetDataset", "horizon.v1.DatasetService/ListDatasets",
              "horizon.v1.VisibilityService/ComputeViewshed", "horizon.v1.VisibilityService/LineOfSight",
              "horizon.v1.VisibilityService/CullBoxes", "horizon.v1.VisibilityService/RegionVisibility",
              "horizon.v1.SessionService/Session", "horizon.v1.TraceService/TraceCamera",
              "horizon.v1.MeshService/ListMeshes", "horizon.v1.MeshService/DescribeMesh",
              "horizon.v1.MeshService/CullMesh"]:
        assert m in methods, (m, methods)
    # Every listed service's methods are described (the health service's were not).
    for s in services:
        assert any(m.startswith(s + "/") for m in methods), (s, methods)

    health = call(buf, address, "grpc.health.v1.Health/Check", {})
    assert health == [{"status": "SERVING"}], health
    dataset = call(buf, address, "horizon.v1.DatasetService/GetDataset", {"name": "rainier"})[0]
    assert dataset["name"] == "rainier" and dataset["width"] == 400 and dataset["epsg"] == 4326, dataset
    assert not dataset.get("source", "").startswith("/"), dataset  # no absolute path leaves the daemon
    los = call(buf, address, "horizon.v1.VisibilityService/LineOfSight",
               {"dataset": "rainier", "lines": [{"from": {"frame": "FRAME_WGS84", "x": -121.7604, "y": 46.8529,
                                                          "height": 2},
                                                 "to": {"frame": "FRAME_WGS84", "x": -121.75, "y": 46.85}}]})[0]
    assert len(los["results"]) == 1 and "distance" in los["results"][0], los
    stream = call(buf, address, "horizon.v1.VisibilityService/ComputeViewshed",
                  {"dataset": "rainier", "observer": {"frame": "FRAME_WGS84", "x": -121.6767, "y": 46.75, "height": 2},
                   "options": {"maxDistance": 5000}})
    assert "header" in stream[0] and "summary" in stream[-1], stream
    assert int(stream[-1]["summary"]["visibleCells"]) > 1000, stream[-1]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--horizond", required=True)
    parser.add_argument("--data-dir", required=True)
    parser.add_argument("--buf", default=shutil.which("buf"))
    args = parser.parse_args()
    if not args.buf or not os.path.exists(args.buf):
        print("skipped: buf is not installed (scripts/setup.sh installs it: npm install -g @bufbuild/buf)")
        return 77
    with tempfile.TemporaryDirectory(prefix="horizond-buf-") as tmp:
        proc, listening, log_path = start_daemon(args.horizond, args.data_dir, tmp)
        try:
            run_checks(args.buf, "127.0.0.1:%d" % int(listening["grpc_port"]))
        except BaseException:
            sys.stderr.write("--- horizond log ---\n" + open(log_path).read()[-6000:] + "\n")
            raise
        finally:
            proc.send_signal(signal.SIGTERM)
            proc.wait(timeout=30)
    print("ok: buf curl through reflection")
    return 0


if __name__ == "__main__":
    sys.exit(main())
