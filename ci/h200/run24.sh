#!/usr/bin/env bash
# H200 host, stop 44 (issue 27): this stop's build (S44A = 8b4d64d: node records for
# the growth's queries, comparisons for a node frame's cells, the holding ancestor by bits,
# the one-cell check without a store-forwarding stall; the same structure) against stop 43's
# (FINAL = 003f31a) and the start (START = e763231); ENV = S44A with the growth's
# schedule read from GR_R (rounds), GR_F (step factor), GR_H (halve after a failure), for the
# schedule study only. The 3.3 M icosphere at 16 threads, seven interleaved rounds; bunny.toml
# at 2 and 16 threads (ci/compare-build.sh, 9 rounds). CPU only; carried: .devbin,
# .models.tar.xz.
set -uo pipefail
. ci/h200/setup-cpu.sh
for round in 1 2 3 4 5 6 7; do
  s3m_build start $B-start
  s3m_build final $B-final
  s3m_build s44a $B-s44a
  s3m_build env-r4h0 $B-env GR_R=4 GR_F=2 GR_H=0
  s3m_build env-r3f4 $B-env GR_R=3 GR_F=4 GR_H=1
done
for t in 2 16; do SCENE=scenes/bunny.toml THREADS=$t RUNS=9 bash ci/compare-build.sh $B-start $B-final $B-s44a; done
uptime
