# Sourced by the CPU-only H200-host scripts from run19 on (`. ci/h200/setup-cpu.sh`): the
# meshes (.models.tar.xz, where carried) under FRAGTRACE_MODEL_PATH, B=.devbin/fragtrace (the
# binaries are $B-NAME), the machine's size and load, and the icosphere scenes of
# ci/measure-build.sh written to $dir.
if [ -f .models.tar.xz ]; then
  mkdir -p /tmp/models && tar xJf .models.tar.xz -C /tmp/models
  export FRAGTRACE_MODEL_PATH=/tmp/models
fi
B=.devbin/fragtrace
nproc; uptime
dir=$(mktemp -d)
bash ci/measure-build.sh --write-scenes "$dir"
