#!/usr/bin/env bash
# Packs the GPU checks for a machine that has a GPU but not this checkout's
# build: the device machine lent through the `device` tool (a bare x86-64
# Debian-like image; nothing installed). Run here after building:
#
#   tests/bench/gpu_device_bundle.sh [BUILD_DIR] [DEM_12M]
#     BUILD_DIR  default build/
#     DEM_12M    default /work/bench-data/everest_utm45n_30m.tif (docs/benchmarks.md says how it is made)
#
# It writes .gpu-bundle/ (git-ignored): bin/test_gpu and bin/bench_viewshed,
# lib/ with every shared library they load except glibc's and the GL/EGL
# loaders (those come from the device's .gl packages and its driver),
# data/dem (the bundled DEMs the tests read), the 12 M-cell DEM, and run.sh.
# On the device, with .gl unpacked as ../.library/device/README.md says:
#
#   run(command='for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig; .gpu-bundle/run.sh',
#       carry=['.gl', '.gpu-bundle'])
#
# run.sh writes $OUT/test_gpu.txt (the agreement, concurrency and fallback
# tests on the hardware device) and $OUT/bench_gpu.txt (BM_AlgorithmDem/0 and
# BM_GpuDem, medians of 3, with device milliseconds; $BENCH_FILTER narrows
# them). The same bundle runs here too (on llvmpipe, with
# BENCH_FILTER='BM_GpuDem/1/0': one-step fragment propagation is 1,853 draws
# there), which is how it was checked.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
build="${1:-build}"
dem="${2:-/work/bench-data/everest_utm45n_30m.tif}"
out=.gpu-bundle
for f in "$build/tests/test_gpu" "$build/tests/bench/bench_viewshed" "$dem"; do
  [[ -f "$f" ]] || { echo "gpu_device_bundle: missing $f (build first; see docs/benchmarks.md for the DEM)" >&2; exit 1; }
done
rm -rf "$out"
mkdir -p "$out/bin" "$out/lib" "$out/data"
cp "$build/tests/test_gpu" "$build/tests/bench/bench_viewshed" "$out/bin/"
cp -r data/dem "$out/data/dem"
cp "$dem" "$out/data/dem12m.tif"
# Libraries: all that ldd resolves, minus glibc and the GLVND/EGL/GL loaders.
skip='^(libc|libm|libdl|librt|libpthread|ld-linux-x86-64|libEGL|libOpenGL|libGL|libGLX|libGLdispatch|libgbm)\.'
for bin in "$out"/bin/*; do
  ldd "$bin" | awk '/=> \// {print $3}'
done | sort -u | while read -r lib; do
  name="$(basename "$lib")"
  [[ "$name" =~ $skip ]] || cp -L "$lib" "$out/lib/$name"
done
cat > "$out/run.sh" <<'RUN'
#!/usr/bin/env bash
# See tests/bench/gpu_device_bundle.sh. Writes into $OUT (or ./gpu-out).
set -uo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
out="${OUT:-gpu-out}"
mkdir -p "$out"
export LD_LIBRARY_PATH="$here/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export HORIZON_TEST_DATA_DIR="$here/data/dem"
{ nvidia-smi -L 2>/dev/null || true; uname -a; nproc; } > "$out/machine.txt"
"$here/bin/test_gpu" > "$out/test_gpu.txt" 2>&1
echo "test_gpu exit $?" >> "$out/test_gpu.txt"
HORIZON_BENCH_DEM="$here/data/dem12m.tif" "$here/bin/bench_viewshed" \
  --benchmark_filter="${BENCH_FILTER:-BM_AlgorithmDem/0|BM_GpuDem}" --benchmark_repetitions=3 \
  --benchmark_report_aggregates_only=true > "$out/bench_gpu.txt" 2>&1
echo "bench_viewshed exit $?" >> "$out/bench_gpu.txt"
tail -3 "$out/test_gpu.txt"; grep median "$out/bench_gpu.txt"
RUN
chmod +x "$out/run.sh"
du -sh "$out"
