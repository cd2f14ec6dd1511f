#!/usr/bin/env bash
# The CPU render profiled on the H200 host (issue 27): perf and its libraries carried in .perf
# (copied from this machine: /usr/bin/perf and the libraries ldd names), .devbin with symbols
# (strip --strip-debug), .models.tar.xz. Counters where the host allows them, then a profile.
set -u
P=$PWD/.perf
perf() { LD_LIBRARY_PATH=$P/lib $P/perf "$@"; }
mkdir -p /tmp/models && tar xJf .models.tar.xz -C /tmp/models; export FRAGTRACE_MODEL_PATH=/tmp/models
cat /proc/sys/kernel/perf_event_paranoid; lscpu | grep -E "Model name|L2|L3|^CPU\(s\)"
perf stat -e cycles,instructions,cache-misses,L1-dcache-load-misses,LLC-load-misses true 2>&1 | tail -12
for v in fragtrace-old fragtrace; do for th in 2 16; do
echo "== $v $th threads"
RAYON_NUM_THREADS=$th perf stat -e task-clock,cycles,instructions,cache-misses,LLC-load-misses,L1-dcache-load-misses .devbin/$v render ci/peers/equal-work.toml --backend cpu --precision f32 --width 1024 --height 1024 -o /tmp/x.png 2>&1 | grep -vE "^\s*$" | tail -12
done; done
RAYON_NUM_THREADS=2 perf record -F 2000 -o /tmp/p.data .devbin/fragtrace render ci/peers/equal-work.toml --backend cpu --precision f32 --width 1024 --height 1024 -o /tmp/x.png 2>&1 | tail -1
perf report -i /tmp/p.data --no-children --percent-limit 1 --stdio 2>/dev/null | grep -v "^#" | grep -v "^$" | head -25
# Run 10 ran this last part alone (docs/bench/h200/run10/one-thread.log).
echo "== 1 thread, OLD vs NEW, 7 rounds interleaved (render ms, task-clock of the whole process)"
for round in 1 2 3 4 5 6 7; do for v in fragtrace-old fragtrace; do
  RAYON_NUM_THREADS=1 perf stat -x, -e task-clock -o /tmp/ps.txt .devbin/$v render ci/peers/equal-work.toml --backend cpu --precision f32 --width 1024 --height 1024 -q -o /tmp/x-$v.png --stats /tmp/s.json
  python3 -c "import json; d=json.load(open('/tmp/s.json')); print('$v round $round: render', round(d['render_ms'],1), 'ms, build', round(d['accel']['build_ms'],1), 'ms, task-clock', open('/tmp/ps.txt').read().strip().splitlines()[-1].split(',')[0], 'ms')"
done; done
