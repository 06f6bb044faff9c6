#!/usr/bin/env bash
# The search-and-rescue grid of seed 000 sec. 3.3 from configs/sar_cessna_95ghz.yaml: targets
# (crashed aircraft, 1.5 m x 2 m blanket, 6 m x 6 m blanket beacon) x 35/95 GHz x weather
# (clear; cloud 1-2 km at 0.5 g/m3; rain 10 mm/h from the ground to 3 km) = 18 renders.
set -euo pipefail
cd "$(dirname "$0")/.."
PMMW=${PMMW:-pmmw}
declare -A weather=(
  [clear]='[]'
  [cloud]='[{kind: cloud, base: 1000 m, top: 2000 m, liquid_water: 0.5 g/m3}]'
  [rain]='[{kind: rain, base: 0 m, top: 3000 m, rain_rate: 10 mm/h}]'
)
map="dry_ground: sar_dry_ground, wet_ground: sar_wet_ground, rocks: sar_rocks, shrubs: oak_leaves"
declare -A target_map=([cessna]="{$map, aircraft: metal}" [blanket]="{$map, blanket: metal}" [beacon]="{$map, blanket: metal}")
for target in cessna blanket beacon; do
  for f in 35 95; do
    for w in clear cloud rain; do
      name="sar_${target}_${f}ghz_${w}"
      "$PMMW" render configs/sar_cessna_95ghz.yaml --out "out/sar/$name" --set name="$name" \
        --set scene[0].mesh="../scenes/sar/sar_${target}.glb" --set scene[0].materials="${target_map[$target]}" \
        --set frequency="$f GHz" \
        --set atmosphere.layers="${weather[$w]}" "$@"
    done
  done
done
