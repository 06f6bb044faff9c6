#!/usr/bin/env bash
# The search-and-rescue grid of Murakowski 2014, sec. 3.3, from configs/sar_cessna_95ghz.yaml:
# targets (crashed aircraft, 1.5 m x 2 m blanket, 6 m x 6 m blanket beacon) x 35/95 GHz x the
# thesis's three weathers = 18 renders into out/sar/<name>/:
#   clear: no weather layer (dry desert air, 4 g/m3, from the base config);
#   cloud: a cloud deck from 1000 m to 2000 m (sec. 3.3.3), 1.3 g/m3 of liquid water (the thesis
#          gives none; this reproduces its path losses, 1.2 dB at 35 GHz and 5.6 dB at 95 GHz);
#   rain:  10 mm/h (Table 3.5) from the ground to 1500 m under the same rain cloud, 1000-2000 m
#          (sec. 3.3.4: "rainclouds ... between 1000 and 2000 m, and the rain a height up to 1500 m").
# Vertical path loss from the search aircraft (3000 m) to the ground, pmmw (thesis), 35 / 95 GHz:
# clear 0.11 / 0.30 dB (0.1 / 0.3), cloud 1.02 / 5.58 dB (1.2 / 5.6), rain 4.87 / 15.2 dB
# (4.8 / 11.7; the thesis's own rain and cloud figures add up to 14.5 dB at 95 GHz).
# Checked in tests/test_scenarios.py (AtmosphereModel.path_loss_db); the skies they make:
# pmmw sky --frequency "95 GHz" --humidity "4 g/m3" --ground-temperature "300 K" --layer "cloud,1000,2000,1.3 g/m3"
# Pass extra pmmw options after the script name, e.g. `configs/sar_sweep.sh --workers 8 --quiet`.
set -euo pipefail
cd "$(dirname "$0")/.."
PMMW=${PMMW:-pmmw}
cloud='{kind: cloud, base: 1000 m, top: 2000 m, liquid_water: 1.3 g/m3}'
declare -A weather=(
  [clear]='[]'
  [cloud]="[$cloud]"
  [rain]="[{kind: rain, base: 0 m, top: 1500 m, rain_rate: 10 mm/h}, $cloud]"
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
