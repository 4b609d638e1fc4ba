#!/usr/bin/env bash
# Session affinity through a real balancer (docs/benchmarks.md, "Sessions
# behind HAProxy").
#
#   tests/bench/session_affinity.sh
#
# Three horizond replicas serve the bundled Rainier DEM behind HAProxy
# (HTTP/2 on both sides, `balance hdr(horizon-session-id)` with consistent
# hashing). Sessions with ids A..F each play a short flight three times
# (`horizon session --server ... --session-id ID`): every replay of an id
# must land on the replica its first play did (counted from the replicas'
# request logs). Then the replica holding session A is stopped, and A is
# played again: it must be answered in full by another replica, which it
# re-opens on from the same first pose, telling every box again. Exits 1
# on any miss. Needs build/ (scripts/build.sh) and haproxy.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
source tests/bench/horizond_lib.sh

horizond=build/server/horizond
horizon=build/client_cli/horizon
command -v haproxy >/dev/null || { echo "session_affinity: needs haproxy (apt-get install haproxy)" >&2; exit 2; }
work=$(mktemp -d)
pids=()
haproxy_pid=
cleanup() {
  for p in "${pids[@]}" $haproxy_pid; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

ports=()
for i in 0 1 2; do
  ports+=("$(free_port)")
  cat >"$work/r$i.json" <<JSON
{"listen": "127.0.0.1:${ports[$i]}", "plaintext": true, "data_root": "$PWD/data/dem",
 "datasets": {"rainier": "rainier_summit_srtm3_400x400.tif"}, "memory_budget_mb": 256,
 "worker_threads": 1, "gpu": {"contexts": 0}, "scratch_dir": "$work", "shutdown_grace_ms": 1000}
JSON
  start_horizond "$horizond" "$work/r$i.json" "$work/r$i.log"
  pids[$i]=$horizond_pid
done

front=$(free_port)
{
  echo "global"
  echo "  maxconn 256"
  echo "defaults"
  echo "  mode http"
  echo "  timeout connect 2s"
  echo "  timeout client 60s"
  echo "  timeout server 60s"
  echo "frontend grpc"
  echo "  bind 127.0.0.1:$front proto h2"
  echo "  default_backend horizond"
  echo "backend horizond"
  echo "  balance hdr(horizon-session-id)"
  echo "  hash-type consistent"
  for i in 0 1 2; do echo "  server r$i 127.0.0.1:${ports[$i]} proto h2 check inter 300ms fall 1 rise 2"; done
} >"$work/haproxy.cfg"
haproxy -f "$work/haproxy.cfg" -db >"$work/haproxy.log" 2>&1 &
haproxy_pid=$!
sleep 1

python3 - "$work" <<'PY'
import random, sys
work = sys.argv[1]
with open(work + "/flight.csv", "w") as f:
    for i in range(30):
        f.write("%.5f,46.8529,3500,250,0\n" % (-121.86 + 0.003 * i))
random.seed(5)
with open(work + "/boxes.csv", "w") as f:
    for i in range(200):
        x, y = random.uniform(-121.91, -121.61), random.uniform(46.68, 46.99)
        f.write("%.5f,%.5f,%.5f,%.5f,0,%.1f\n" % (x, y, x + 0.0015, y + 0.001, random.uniform(1500, 4200)))
PY

play() {  # play ID: the flight as session ID through the balancer; prints its JSON
  "$horizon" session rainier --server "127.0.0.1:$front" --session-id "$1" --path "$work/flight.csv" \
    --boxes "$work/boxes.csv" --lonlat --absolute --level-size 64 --subtile 16 --json
}
sessions_on() { grep -c '"method":"Session"' "$work/r$1.log" || true; }
holder() {  # the replica whose Session count grew since the counts in $1
  local before=($1) i
  for i in 0 1 2; do
    if (($(sessions_on "$i") > before[i])); then echo "$i"; return; fi
  done
  echo "none"
}
counts() { echo "$(sessions_on 0) $(sessions_on 1) $(sessions_on 2)"; }

declare -A home
misses=0
for id in A B C D E F; do
  for round in 1 2 3; do
    before=$(counts)
    play "$id" >"$work/$id.$round.json"
    sleep 0.2  # the request log line is written as the stream ends
    at=$(holder "$before")
    if [[ $round == 1 ]]; then
      home[$id]=$at
    elif [[ $at != "${home[$id]}" ]]; then
      echo "session_affinity: session $id went to replica $at, first to ${home[$id]}" >&2
      misses=$((misses + 1))
    fi
  done
  echo "session $id: 3 plays, all on replica ${home[$id]}"
done
spread=$(printf '%s\n' "${home[@]}" | sort -u | wc -l)
echo "6 sessions over $spread replicas: $(counts) session calls (replicas 0 1 2)"

# The replica holding A stops (SIGTERM: it drains); A plays again through the balancer.
victim=${home[A]}
kill -TERM "${pids[$victim]}"
wait "${pids[$victim]}" 2>/dev/null || true
pids[$victim]=
sleep 1  # past the health check's 300 ms
before=$(counts)
play A >"$work/A.after.json"
sleep 0.2
at=$(holder "$before")
python3 - "$work/A.after.json" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
assert j["answered"] == 30 and j["rejected"] == 0, j
first = j["poses"][0]
assert first["changes"] == first["boxes"] == 200, first  # re-opened: every box told again
print("session A after its replica stopped: %d of 30 poses answered, the first told all %d boxes"
      % (j["answered"], first["changes"]))
PY
if [[ $at == "none" || $at == "$victim" ]]; then
  echo "session_affinity: session A was not answered by another replica" >&2
  misses=$((misses + 1))
else
  echo "session A re-opened on replica $at (replica $victim stopped)"
fi
((misses == 0)) || exit 1
echo "session_affinity: ok"
