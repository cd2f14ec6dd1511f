set -uo pipefail
. ci/h200/setup.sh
START=.devbin/fragtrace-start BAL=.devbin/fragtrace-bal BAL1K=.devbin/fragtrace-bal1k
for t in 16 2; do
  for s in scenes/bunny.toml; do
    SCENE=$s THREADS=$t RUNS=9 bash ci/compare-build.sh $OLD $NEW $BAL $BAL1K
  done
done
for b in $START $BAL $BAL1K $BAL1K $BAL $START; do echo "-- irregular, $b"; bash ci/measure-build.sh $b irregular 16; done
