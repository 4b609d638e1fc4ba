# horizond_lib.sh — sourced by the daemon bench scripts (ab_daemon.sh,
# soak.sh, scale_out.sh, session_affinity.sh).
#
#   start_horizond BIN CONFIG LOG
#
# Starts BIN --config CONFIG with its log in LOG and waits (up to 120 s) for
# its datasets to load. Sets horizond_pid, horizond_port (the gRPC port it
# bound) and horizond_metrics_port (0 when off). When it exits or does not
# come up, prints its log and exits 1.
start_horizond() {
  local bin=$1 config=$2 log=$3
  "$bin" --config "$config" 2>"$log" &
  horizond_pid=$!
  for _ in $(seq 1200); do
    grep -q '"datasets_loaded"' "$log" && break
    if ! kill -0 "$horizond_pid" 2>/dev/null; then
      echo "horizond did not start:" >&2
      cat "$log" >&2
      exit 1
    fi
    sleep 0.1
  done
  grep -q '"datasets_loaded"' "$log" || { echo "horizond did not load its datasets in 120 s" >&2; exit 1; }
  horizond_port=$(grep -o '"grpc_port":[0-9]*' "$log" | head -1 | cut -d: -f2)
  horizond_metrics_port=$(grep -o '"metrics_port":[0-9]*' "$log" | head -1 | cut -d: -f2)
}

# A loopback TCP port free now (for a config that must name its port).
free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
