#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Wall time of plumb lio (hybrid) and plumb run on 1 and 2 threads, same dumps.
set -e
cd "$(dirname "$0")/.."
P=build/rel/examples/plumb
FZK=${PLUMB_DATA_DIR:-../shared/data}/ifc/buildings/AC20-FZK-Haus.ifc
OFFICE=examples/data/demo_office.ifc
[ -d /tmp/tb_site ] || $P simulate $FZK -o /tmp/tb_site --scenario site --seed 1 --length 60 --overwrite > /dev/null
[ -d /tmp/tb_run ] || $P simulate $OFFICE -o /tmp/tb_run --length 30 --seed 3 --overwrite > /dev/null
for t in 1 2; do
  /usr/bin/time -f "lio threads $t: %e s wall, %U s user" $P lio /tmp/tb_site --mode hybrid --threads $t -o /tmp/tb_lio_$t --overwrite > /dev/null
done
for t in 1 2; do
  /usr/bin/time -f "run threads $t: %e s wall, %U s user" $P run /tmp/tb_run --bim $OFFICE --gt-start --threads $t -o /tmp/tb_runout_$t --overwrite > /dev/null
done
cmp /tmp/tb_lio_1/trajectory.tum /tmp/tb_lio_2/trajectory.tum && echo "lio trajectories identical"
cmp /tmp/tb_runout_1/bim.tum /tmp/tb_runout_2/bim.tum && echo "run trajectories identical"
