#!/usr/bin/env bash
# H200 host, stop 44 (issue 27): this stop's build (S44 = a798781: node records for the
# growth's queries, comparisons for a node frame's cells, the holding ancestor by bits, the
# split levels worked out once, no store-forwarding stall in the one-cell check, array maps
# written out; the same structure as e763231's) against stop 43's (FINAL = 003f31a) and the
# issue's start (START = e763231): the 3.3 M icosphere at 16 threads, nine interleaved
# rounds; bunny.toml at 2 and 16 threads (ci/compare-build.sh, 11 rounds). CPU only;
# carried: .devbin, .models.tar.xz. NEW names this stop's binary ($B-NEW, s44 by default;
# run26.sh: s44b).
set -uo pipefail
. ci/h200/setup-cpu.sh
NEW=${NEW:-s44}
for round in 1 2 3 4 5 6 7 8 9; do
  for b in start final $NEW; do
    s3m_build $b $B-$b
  done
done
for t in 2 16; do SCENE=scenes/bunny.toml THREADS=$t RUNS=11 bash ci/compare-build.sh $B-start $B-final $B-$NEW; done
uptime
