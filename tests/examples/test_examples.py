#!/usr/bin/env python3
"""Every example of README.md, docs/api.md and each command's --help, run as
printed against the shipped files: the bundled DEMs (data/dem), the example
inputs and the daemon's config (examples/).

The examples run in a scratch folder that holds `data`, `examples` and
`build` as links to the checkout and its build, with the build's `horizon`
and `horizond` on PATH (the --help texts say plain `horizon`). One daemon
runs from examples/horizond.json, started as the README starts it; the one
change made to what is printed is its port: the daemon listens on a free
port instead of 50051 (another daemon may hold that one), and every
`localhost:50051` is rewritten to it. Each command must exit 0; the README's
quick-start viewsheds must see a sensible share of their cells.

Not run: the Python snippet of docs/api.md (a fragment), the TLS example
(`horizon.example`, a host that is not there), and scripts/demo.sh and
scripts/test.sh (they install and build; test.sh runs this suite).
"""
import argparse
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

SKIP = [("horizon.example", "a TLS daemon on another host"),
        ("scripts/demo.sh", "installs and builds; CI runs the demo's viewshed through the README's own lines"),
        ("scripts/test.sh", "runs this very suite")]


def bash_blocks(markdown_path):
    blocks, current = [], None
    for line in open(markdown_path, encoding="utf-8"):
        if current is None and line.strip() == "```bash":
            current = []
        elif current is not None and line.strip() == "```":
            blocks.append(current)
            current = None
        elif current is not None:
            current.append(line.rstrip("\n"))
    return blocks


def commands_of(lines):
    """Lines joined at trailing backslashes and at open single quotes (buf curl -d '{...}')."""
    out, pending = [], ""
    for line in lines:
        pending = pending + "\n" + line if pending else line
        if pending.endswith("\\") or pending.count("'") % 2 == 1:
            continue
        if pending.strip():
            out.append(pending)
        pending = ""
    if pending.strip():
        out.append(pending)
    return out


def help_examples(horizon):
    listing = subprocess.run([horizon, "--help"], capture_output=True, text=True, check=True).stdout
    names = re.findall(r"^  ([a-z]+)  ", listing.split("Commands:")[1], re.M)
    examples = {}
    for name in names:
        text = subprocess.run([horizon, name, "--help"], capture_output=True, text=True, check=True).stdout
        if "Examples:" not in text:
            continue
        lines = []
        for line in text.split("Examples:", 1)[1].splitlines()[1:]:
            if not line.strip():
                break
            lines.append(line.strip() if not line.startswith("      ") else "    " + line.strip())
        examples[name] = commands_of(lines)
    return names, examples


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--source", required=True)
    parser.add_argument("--build", required=True)
    args = parser.parse_args()
    source, build = os.path.abspath(args.source), os.path.abspath(args.build)
    horizon = os.path.join(build, "client_cli", "horizon")

    examples = []  # (where, command)
    for doc in ["README.md", "docs/api.md"]:
        for block in bash_blocks(os.path.join(source, doc)):
            examples += [(doc, c) for c in commands_of(block)]
    names, helps = help_examples(horizon)
    for name, cmds in helps.items():
        examples += [("horizon %s --help" % name, c) for c in cmds]
    assert len(helps) == len(names), "every command's --help has examples: %s of %s" % (sorted(helps), names)

    port = free_port()
    failures, ran, skipped = [], 0, 0
    with tempfile.TemporaryDirectory(prefix="horizon-examples-") as tmp:
        for name, target in [("data", os.path.join(source, "data")), ("examples", os.path.join(source, "examples")),
                             ("build", build)]:
            os.symlink(target, os.path.join(tmp, name))
        env = dict(os.environ)
        env["PATH"] = os.path.join(build, "client_cli") + os.pathsep + os.path.join(build, "server") + os.pathsep + \
            env.get("PATH", "")
        log_path = os.path.join(tmp, "horizond.log")
        daemon = None
        try:
            for where, command in examples:
                reason = next((why for key, why in SKIP if key in command), None)
                if reason:
                    print("skip (%s): %s" % (reason, command.splitlines()[0]))
                    skipped += 1
                    continue
                if command.startswith("buf ") and not shutil.which("buf"):
                    print("skip (buf is not installed): %s" % command.splitlines()[0])
                    skipped += 1
                    continue
                command = command.replace("localhost:50051", "localhost:%d" % port)
                if re.match(r"^(build/server/)?horizond --config \S+ &", command):
                    # The README's daemon, on the free port; the test waits for it as a person would.
                    config = command.split("--config", 1)[1].split()[0]
                    daemon = subprocess.Popen(
                        [os.path.join(build, "server", "horizond"), "--config", config, "--listen",
                         "127.0.0.1:%d" % port, "--metrics-listen", "127.0.0.1:0"],
                        cwd=tmp, stderr=open(log_path, "w"))
                    for _ in range(500):
                        if '"datasets_loaded"' in open(log_path).read():
                            break
                        time.sleep(0.02)
                    print("ok    %-22s %s (port %d)" % (where, command.splitlines()[0], port))
                    ran += 1
                    continue
                if "--server" in command and daemon is None:
                    failures.append((where, command, "needs the daemon, which no example started before it"))
                    continue
                started = time.time()
                run = subprocess.run(["bash", "-c", command], cwd=tmp, env=env, capture_output=True, text=True,
                                     timeout=600)
                seconds = time.time() - started
                ran += 1
                first = command.splitlines()[0]
                if run.returncode != 0:
                    failures.append((where, command, "exit %d\n%s%s" % (run.returncode, run.stdout[-2000:],
                                                                       run.stderr[-2000:])))
                    print("FAIL  %-22s %s" % (where, first))
                    continue
                print("ok    %-22s %s  (%.1f s)" % (where, first, seconds))
                # A first-time user's viewshed sees something: the README's quick starts.
                if where == "README.md" and " viewshed " in command and "--observers" not in command:
                    m = re.search(r"visible:\s+([\d,]+) cells", run.stdout)
                    if m and int(m.group(1).replace(",", "")) < 1000:
                        failures.append((where, command, "only %s cells visible" % m.group(1)))
        finally:
            if daemon is not None:
                daemon.send_signal(signal.SIGTERM)
                daemon.wait(timeout=30)
        if daemon is None:
            failures.append(("README.md", "horizond --config examples/horizond.json &", "no example started it"))
    for where, command, why in failures:
        sys.stderr.write("\n--- %s: %s\n%s\n" % (where, command, why))
    print("%d examples run, %d skipped, %d failed" % (ran, skipped, len(failures)))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
