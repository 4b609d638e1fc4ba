#!/usr/bin/env python3
"""The deploy files are well-formed and their configs are accepted by horizond:
the Kubernetes YAML parses (python3-yaml), holds a ConfigMap, a Deployment with
gRPC probes and a read-only DEM volume, and a Service; the ConfigMap's JSON and
deploy/horizond.json pass `horizond --check-config` with --data-root set to the
bundled DEMs (which the configs name)."""
import argparse
import os
import subprocess
import sys
import tempfile

import yaml


def check_config(horizond, text, data_dir):
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        f.write(text)
        path = f.name
    try:
        r = subprocess.run([horizond, "--check-config", path, "--data-root", data_dir], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        assert "accepted" in r.stdout, r.stdout
    finally:
        os.unlink(path)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--horizond", required=True)
    p.add_argument("--deploy-dir", required=True)
    p.add_argument("--data-dir", required=True)
    a = p.parse_args()
    docs = list(yaml.safe_load_all(open(os.path.join(a.deploy_dir, "kubernetes", "horizond.yaml"))))
    kinds = {d["kind"]: d for d in docs}
    assert set(kinds) == {"ConfigMap", "Deployment", "Service"}, kinds.keys()
    container = kinds["Deployment"]["spec"]["template"]["spec"]["containers"][0]
    assert container["readinessProbe"]["grpc"]["port"] == 50051
    assert container["livenessProbe"]["grpc"]["port"] == 50051
    mounts = {m["name"]: m for m in container["volumeMounts"]}
    assert mounts["dem"]["readOnly"] is True
    assert kinds["Deployment"]["spec"]["template"]["spec"]["securityContext"]["runAsNonRoot"] is True
    check_config(a.horizond, kinds["ConfigMap"]["data"]["horizond.json"], a.data_dir)
    check_config(a.horizond, open(os.path.join(a.deploy_dir, "horizond.json")).read(), a.data_dir)
    # A bad config is refused, naming the key.
    r = subprocess.run([a.horizond, "--check-config", "/dev/null"], capture_output=True, text=True)
    assert r.returncode == 1
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        f.write('{"listen": "0.0.0.0:50051", "data_root": "%s", "datasets": {"x": "../../etc/passwd"}, '
                '"memory_budget_mb": 256}' % a.data_dir)
    r = subprocess.run([a.horizond, "--check-config", f.name], capture_output=True, text=True)
    os.unlink(f.name)
    assert r.returncode == 1 and "datasets.x" in r.stderr and "outside data_root" in r.stderr, r.stderr
    print("ok: deploy files")


if __name__ == "__main__":
    main()
