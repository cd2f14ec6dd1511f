#!/usr/bin/env bash
# H200 host, stop 42 (issue 27): the irregular build after this stop's passes (the voxel map
# built straight into the final layout, exit boxes grown in place, the summed-volume early
# answer), against the start and the session's start. START = e763231, OLD =
# 1b70342 (stop 41), NEW = this stop. ci/measure-build.sh's icospheres at 16 and 2 threads
# (START OLD NEW, then NEW OLD START); bunny.toml and the equal-work bunny, interleaved,
# 16 and 2 threads. Carried: .gl, .devbin, .models.tar.xz.
set -uo pipefail
. ci/h200/setup.sh
START=.devbin/fragtrace-start
nproc; uptime
for b in $START $OLD $NEW $NEW $OLD $START; do echo "-- irregular, $b"; bash ci/measure-build.sh $b irregular 16 2; done
for t in 16 2; do
  for s in scenes/bunny.toml ci/peers/equal-work.toml; do
    SCENE=$s THREADS=$t RUNS=7 bash ci/compare-build.sh $START $OLD $NEW
  done
done
