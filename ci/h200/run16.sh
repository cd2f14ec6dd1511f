#!/usr/bin/env bash
# H200 host, stop 42 (issue 27): the irregular build's last two passes on 16 cores. START =
# e763231 (the start), OLD = 1b70342 (stop 41), APP = a8474b4 plus the parallel
# append (the map built straight into the final layout, exit boxes grown in place, the
# summed-volume early answer), NEW = be42dce (one tight box per node, found through a slot
# per entry). ci/measure-build.sh's icospheres at 16 and 2 threads, START APP NEW then NEW
# APP START; bunny.toml and the equal-work bunny interleaved at 16 and 2 threads.
# Carried: .gl, .devbin, .models.tar.xz.
set -uo pipefail
. ci/h200/setup.sh
START=.devbin/fragtrace-start APP=.devbin/fragtrace-app
nproc; uptime
for b in $START $APP $NEW $NEW $APP $START; do echo "-- irregular, $b"; bash ci/measure-build.sh $b irregular 16 2; done
for t in 16 2; do
  for s in scenes/bunny.toml ci/peers/equal-work.toml; do
    SCENE=$s THREADS=$t RUNS=7 bash ci/compare-build.sh $START $OLD $APP $NEW
  done
done
