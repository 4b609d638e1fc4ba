#!/usr/bin/env bash
# Two horizond builds, alternating, under the same load (docs/benchmarks.md,
# "Daemon (horizond)"): for a change that must not make the daemon slower.
#
#   tests/bench/ab_daemon.sh OLD_HORIZOND NEW_HORIZOND DEM X Y [ROUNDS]
#
# Each round starts OLD then NEW (one at a time) serving DEM with
# {"worker_threads": 2, "engine_threads": 1, "memory_budget_mb": 1024,
# "gpu": {"contexts": 0}} and runs tests/bench/load_horizond against it:
# culling (1 client, 600 calls of a new viewpoint and 10 000 boxes within
# 3 km of X,Y) and viewsheds (1 client, 100 calls, 10 km). Prints one
# load_horizond line per daemon, scenario and round (default 3 rounds).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
source tests/bench/horizond_lib.sh
if (($# < 5)); then
  sed -n '2,12p' "$0" >&2
  exit 2
fi
old=$(realpath "$1")
new=$(realpath "$2")
dem=$(realpath "$3")
x=$4
y=$5
rounds=${6:-3}
load=build/tests/bench/load_horizond
work=$(mktemp -d)
pid=
trap '[[ -n "$pid" ]] && kill "$pid" 2>/dev/null; wait 2>/dev/null; rm -rf "$work"' EXIT
cat >"$work/legacy.json" <<JSON
{"listen": "127.0.0.1:0", "data_root": "$(dirname "$dem")", "datasets": {"dem": "$(basename "$dem")"},
 "memory_budget_mb": 1024, "worker_threads": 2, "engine_threads": 1, "gpu": {"contexts": 0}}
JSON
# Builds since the tls/plaintext keys need "plaintext": true; older ones refuse the key.
sed 's/^{/{"plaintext": true, /' "$work/legacy.json" >"$work/plaintext.json"
for round in $(seq "$rounds"); do
  for which in old new; do
    bin=$old
    [[ $which == new ]] && bin=$new
    config=$work/plaintext.json
    "$bin" --check-config "$config" >/dev/null 2>&1 || config=$work/legacy.json
    start_horizond "$bin" "$config" "$work/log"
    pid=$horizond_pid
    port=$horizond_port
    echo "round $round $which cull:     $("$load" --server "127.0.0.1:$port" --dataset dem --mode cull --x "$x" --y "$y" \
      --clients 1 --requests 600 --boxes 10000 --scene-radius 3000)"
    echo "round $round $which viewshed: $("$load" --server "127.0.0.1:$port" --dataset dem --mode viewshed --x "$x" \
      --y "$y" --clients 1 --requests 100 --max-distance 10000)"
    kill "$pid"
    wait "$pid" 2>/dev/null || true
    pid=
  done
done
