#!/usr/bin/env bash
# H200 host, stop 42 (issue 27): the leaner emptiness query (per-level tables, the children
# as a bit set, the "covers the node" test at the first node only) measured where the
# machine is quiet enough to see it. NEW = 72de9d6 (this stop without it), LEAN = NEW with
# it, START = e763231. bunny.toml and the equal-work bunny interleaved at 16 and 2 threads,
# 11 rounds; ci/measure-build.sh's icospheres at 16 and 2 threads, START NEW LEAN then back.
# Carried: .gl, .devbin, .models.tar.xz.
set -uo pipefail
. ci/h200/setup.sh
START=.devbin/fragtrace-start LEAN=.devbin/fragtrace-lean
nproc; uptime
for t in 16 2; do
  for s in scenes/bunny.toml ci/peers/equal-work.toml; do
    SCENE=$s THREADS=$t RUNS=11 bash ci/compare-build.sh $START $NEW $LEAN
  done
done
for b in $START $NEW $LEAN $LEAN $NEW $START; do echo "-- irregular, $b"; bash ci/measure-build.sh $b irregular 16 2; done
