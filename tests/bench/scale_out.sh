#!/usr/bin/env bash
# Scale-out on real infrastructure, loopback only: horizond replicas behind
# HAProxy (Debian's haproxy, HTTP/2 to the clients and to each replica,
# round robin per call, HTTP health checks of each replica's /healthz on its
# metrics port every 300 ms: out of rotation while it loads or drains, or
# when it is gone). Three phases, each
# SECONDS long with CLIENTS clients of load_horizond --retry 1 (the channel
# retries UNAVAILABLE, as a client of replicas should):
#   1. one replica behind the balancer: the baseline throughput;
#   2. three replicas: the same load spread (each replica's request count
#      from its metrics);
#   3. three replicas, one killed (SIGKILL) a third of the way in and started
#      again at two thirds: the client must lose no call, the balancer drops
#      the dead replica and takes it back once its port answers.
#
#   tests/bench/scale_out.sh DEM.tif X Y [CLIENTS=8] [SECONDS=20] [MODE=cull]
#
# Exit 0 when no phase saw an error other than refusals. docs/benchmarks.md
# quotes a run.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
source tests/bench/horizond_lib.sh

if (($# < 3)); then
  sed -n '2,18p' "$0" >&2
  exit 2
fi
dem=$(realpath "$1")
x=$2
y=$3
clients=${4:-8}
seconds=${5:-20}
mode=${6:-cull}
horizond=build/server/horizond
load=build/tests/bench/load_horizond
command -v haproxy >/dev/null || { echo "scale_out: needs haproxy (apt-get install haproxy)" >&2; exit 2; }
work=$(mktemp -d)
pids=()
haproxy_pid=
cleanup() {
  for p in "${pids[@]}" $haproxy_pid; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT


# Replica i on a fixed port (the balancer's config names it), metrics on another.
ports=() metrics=()
for i in 0 1 2; do ports+=("$(free_port)"); metrics+=("$(free_port)"); done
start_replica() {
  local i=$1
  cat >"$work/r$i.json" <<JSON
{"listen": "127.0.0.1:${ports[$i]}", "plaintext": true, "metrics_listen": "127.0.0.1:${metrics[$i]}",
 "data_root": "$(dirname "$dem")", "datasets": {"dem": "$(basename "$dem")"}, "memory_budget_mb": 768,
 "worker_threads": 1, "engine_threads": 1, "gpu": {"contexts": 0}, "scratch_dir": "$work",
 "shutdown_grace_ms": 2000}
JSON
  start_horizond "$horizond" "$work/r$i.json" "$work/r$i.log"
  pids[$i]=$horizond_pid
}
served() { curl -s "http://127.0.0.1:${metrics[$1]}/metrics" | awk '/^horizon_requests_total/ {n += $2} END {print n + 0}'; }

front=$(free_port)
balance() {  # the replicas given, behind one frontend
  {
    echo "global"
    echo "  maxconn 4096"
    echo "defaults"
    echo "  mode http"
    echo "  timeout connect 1s"
    echo "  timeout client 60s"
    echo "  timeout server 60s"
    echo "  retries 2"
    echo "  option redispatch"
    echo "frontend grpc"
    echo "  bind 127.0.0.1:$front proto h2"
    echo "  default_backend horizond"
    echo "backend horizond"
    echo "  balance roundrobin"
    echo "  option httpchk"
    echo "  http-check send meth GET uri /healthz"
    echo "  http-check expect string \"horizon_serving 1\""
    for i in "$@"; do
      echo "  server r$i 127.0.0.1:${ports[$i]} proto h2 check port ${metrics[$i]} check-proto h1 inter 300ms fall 1 rise 2"
    done
  } >"$work/haproxy.cfg"
  [[ -n "$haproxy_pid" ]] && { kill "$haproxy_pid"; wait "$haproxy_pid" 2>/dev/null || true; }
  haproxy -q -f "$work/haproxy.cfg" &
  haproxy_pid=$!
  sleep 1
}
run_load() {
  "$load" --server "127.0.0.1:$front" --dataset dem --mode "$mode" --x "$x" --y "$y" --clients "$clients" \
    --seconds "$seconds" --boxes 2000 --max-distance 10000 --scene-radius 3000 --retry 1 2>&1 | tail -1
}

status=0
for i in 0 1 2; do start_replica "$i"; done
echo "scale_out: replicas on ${ports[*]}, balancer on $front; $clients clients, $mode, ${seconds} s a phase"

balance 0
line=$(run_load)
echo "phase 1, one replica:    $line"
[[ $line == *" 0 errors,"* ]] || status=1
balance 0 1 2
before=("$(served 0)" "$(served 1)" "$(served 2)")
line=$(run_load)
echo "phase 2, three replicas: $line"
[[ $line == *" 0 errors,"* ]] || status=1
echo "  calls per replica: $(( $(served 0) - before[0] )) $(( $(served 1) - before[1] )) $(( $(served 2) - before[2] ))"

(
  sleep "$(python3 -c "print($seconds / 3)")"
  kill -9 "${pids[1]}"
  echo "  replica 1 killed (SIGKILL) at $(date +%T)"
) &
killer=$!
(
  sleep "$(python3 -c "print(2 * $seconds / 3)")"
  echo "  replica 1 restarting at $(date +%T)"
) &
restarter=$!
load_out=$work/phase3
"$load" --server "127.0.0.1:$front" --dataset dem --mode "$mode" --x "$x" --y "$y" --clients "$clients" \
  --seconds "$seconds" --boxes 2000 --max-distance 10000 --scene-radius 3000 --retry 1 >"$load_out" 2>&1 &
load_pid=$!
wait "$killer"
wait "$restarter"
start_replica 1
after_return=$(served 1)
phase3_status=0
wait "$load_pid" || phase3_status=$?
echo "phase 3, one replica killed and restarted: $(tail -1 "$load_out")"
echo "  calls the restarted replica served before the load ended: $(( $(served 1) - after_return ))"
grep -q " 0 errors," "$load_out" || status=1
((phase3_status == 0)) || status=1
if ((status == 0)); then echo "scale_out: no call lost"; else echo "scale_out: calls failed" >&2; fi
exit "$status"
