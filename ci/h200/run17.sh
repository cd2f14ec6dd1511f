#!/usr/bin/env bash
# H200 host, stop 42 (issue 27): the runs of top cells cut by references. OLD = 1b70342
# (stop 41), NEW = be42dce, BAL = be42dce with the runs cut by references (0accbc6), BAL1K =
# BAL with PAR_SPLIT 1024 (tried, not kept). bunny.toml interleaved at 16 and 2 threads,
# 9 rounds; ci/measure-build.sh's icospheres at 16 threads, START BAL BAL1K then back.
# Carried: .gl, .devbin, .models.tar.xz.
set -uo pipefail
. ci/h200/setup.sh
START=.devbin/fragtrace-start BAL=.devbin/fragtrace-bal BAL1K=.devbin/fragtrace-bal1k
for t in 16 2; do
  for s in scenes/bunny.toml; do
    SCENE=$s THREADS=$t RUNS=9 bash ci/compare-build.sh $OLD $NEW $BAL $BAL1K
  done
done
for b in $START $BAL $BAL1K $BAL1K $BAL $START; do echo "-- irregular, $b"; bash ci/measure-build.sh $b irregular 16; done
