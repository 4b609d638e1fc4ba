#!/usr/bin/env python3
"""The deploy files are well-formed and their configs are accepted by horizond:
the Kubernetes YAML parses (python3-yaml), holds a ConfigMap, a Deployment with
gRPC probes and a read-only DEM volume, and a Service; the ConfigMap's JSON and
deploy/horizond.json pass `horizond --check-config` with --data-root set to the
bundled DEMs (which the configs name)."""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import yaml


def check_config(horizond, text, data_dir):
    """The shipped config is safe by default (TLS, tokens, metrics on loopback,
    never plaintext), and horizond accepts it once the secrets it names exist:
    here a certificate and tokens made for the test stand in for the mounts."""
    config = json.loads(text)
    assert "tls" in config and not config.get("plaintext", False), config
    assert "auth_tokens_file" in config, config
    assert config.get("metrics_listen", "").startswith("127.0.0.1:"), config
    with tempfile.TemporaryDirectory() as tmp:
        r = subprocess.run(["openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
                            "-nodes", "-keyout", os.path.join(tmp, "tls.key"), "-out", os.path.join(tmp, "tls.crt"),
                            "-days", "1", "-subj", "/CN=horizond"], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        with open(os.path.join(tmp, "tokens"), "w") as f:
            f.write("a-deploy-test-token-0123456789\n")
        config["tls"]["cert_file"] = os.path.join(tmp, "tls.crt")
        config["tls"]["key_file"] = os.path.join(tmp, "tls.key")
        config["auth_tokens_file"] = os.path.join(tmp, "tokens")
        path = os.path.join(tmp, "horizond.json")
        with open(path, "w") as f:
            json.dump(config, f)
        r = subprocess.run([horizond, "--check-config", path, "--data-root", data_dir], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        assert "accepted" in r.stdout, r.stdout


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--horizond", required=True)
    p.add_argument("--deploy-dir", required=True)
    p.add_argument("--data-dir", required=True)
    a = p.parse_args()
    docs = list(yaml.safe_load_all(open(os.path.join(a.deploy_dir, "kubernetes", "horizond.yaml"))))
    kinds = {d["kind"]: d for d in docs}
    assert sorted(d["kind"] for d in docs) == ["ConfigMap", "Deployment", "HorizontalPodAutoscaler",
                                               "PodDisruptionBudget", "Service", "Service"], [d["kind"] for d in docs]
    services = {d["metadata"]["name"]: d for d in docs if d["kind"] == "Service"}
    assert services["horizond-pods"]["spec"]["clusterIP"] == "None"  # headless, for client-side round robin
    labels = kinds["Deployment"]["spec"]["selector"]["matchLabels"]
    assert kinds["PodDisruptionBudget"]["spec"]["selector"]["matchLabels"] == labels
    assert kinds["HorizontalPodAutoscaler"]["spec"]["scaleTargetRef"]["name"] == kinds["Deployment"]["metadata"]["name"]
    container = kinds["Deployment"]["spec"]["template"]["spec"]["containers"][0]
    # Kubernetes' gRPC probes speak no TLS: they use the plaintext health-only port.
    assert container["readinessProbe"]["grpc"]["port"] == 50052
    assert container["livenessProbe"]["grpc"]["port"] == 50052
    secrets = {v["secret"]["secretName"] for v in kinds["Deployment"]["spec"]["template"]["spec"]["volumes"]
               if "secret" in v}
    assert secrets == {"horizond-tls", "horizond-tokens"}, secrets
    mounts = {m["name"]: m for m in container["volumeMounts"]}
    assert mounts["dem"]["readOnly"] is True
    assert kinds["Deployment"]["spec"]["template"]["spec"]["securityContext"]["runAsNonRoot"] is True
    # The memory limit holds the budget and the overhead outside it, and no more than 25 % on top.
    config = json.loads(kinds["ConfigMap"]["data"]["horizond.json"])
    def mebibytes(q):
        return int(q[:-2]) * (1024 if q.endswith("Gi") else 1) if q[-2:] in ("Mi", "Gi") else int(q) >> 20
    limit = mebibytes(container["resources"]["limits"]["memory"])
    assert config["memory_budget_mb"] + 128 <= limit <= 1.25 * config["memory_budget_mb"], limit
    assert mebibytes(container["resources"]["requests"]["memory"]) >= config["memory_budget_mb"]
    check_config(a.horizond, kinds["ConfigMap"]["data"]["horizond.json"], a.data_dir)
    check_config(a.horizond, open(os.path.join(a.deploy_dir, "horizond.json")).read(), a.data_dir)
    # A bad config is refused, naming the key.
    r = subprocess.run([a.horizond, "--check-config", "/dev/null"], capture_output=True, text=True)
    assert r.returncode == 1
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        f.write('{"listen": "0.0.0.0:50051", "plaintext": true, "data_root": "%s", '
                '"datasets": {"x": "../../etc/passwd"}, "memory_budget_mb": 256}' % a.data_dir)
    r = subprocess.run([a.horizond, "--check-config", f.name], capture_output=True, text=True)
    os.unlink(f.name)
    assert r.returncode == 1 and "datasets.x" in r.stderr and "outside data_root" in r.stderr, r.stderr
    print("ok: deploy files")


if __name__ == "__main__":
    main()
