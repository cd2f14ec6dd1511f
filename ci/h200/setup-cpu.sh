# Sourced by the CPU-only H200-host scripts from run19 on (`. ci/h200/setup-cpu.sh`): the
# meshes (.models.tar.xz, where carried) under FRAGTRACE_MODEL_PATH, B=.devbin/fragtrace (the
# binaries are $B-NAME), the machine's size and load, the icosphere scenes of
# ci/measure-build.sh written to $dir, and s3m_build (run24 on).
if [ -f .models.tar.xz ]; then
  mkdir -p /tmp/models && tar xJf .models.tar.xz -C /tmp/models
  export FRAGTRACE_MODEL_PATH=/tmp/models
fi
B=.devbin/fragtrace
nproc; uptime
dir=$(mktemp -d)
bash ci/measure-build.sh --write-scenes "$dir"

# s3m_build NAME BINARY [VAR=VALUE...]: one irregular build of the 3.3 M icosphere on 16
# threads, printed as "s3m 16 NAME built in ... ms (...) SECONDS s FAULTS minfl".
s3m_build() {
  local name=$1 bin=$2; shift 2
  env "$@" RAYON_NUM_THREADS=16 /usr/bin/time -f "%e s %R minfl" -o $dir/t.txt $bin render $dir/s3m.toml --backend cpu --accel irregular --width 8 --height 8 -q -o $dir/x.png --stats $dir/s.json
  python3 -c "import json,re; d=json.load(open('$dir/s.json')); m=re.search(r'built in .*', d['accel']['detail']); print('s3m 16 $name', m.group(0), open('$dir/t.txt').read().strip())"
}
