#!/usr/bin/env bash
# The landing scenario grid of Murakowski 2014, sec. 3.1, from one base config: 2 frequencies x 2 ranges
# x 3 weathers x 2 beacon styles = 24 renders into out/landing/<f>_<range>_<weather>_<style>/.
# Weathers (Murakowski 2014, Table 3.2), all in the base config's humid air (15 g/m3 at 288 K):
# cloudy (the table's 0 g/m3 row: no fog, no liquid water; 0.19 / 0.92 dB/km at 35 / 95 GHz,
# table 0.17 / 0.92), heavy fog 0.3 g/m3 (0.40 / 2.15; table 0.40 / 2.29) and extreme fog 1 g/m3
# (0.90 / 5.01; table 0.88 / 5.05), fog from the ground to 600 m. Pass extra pmmw options after
# the script name, e.g. `configs/landing_sweep.sh --workers 8 --quiet`.
set -euo pipefail
cd "$(dirname "$0")/.."
PMMW=${PMMW:-pmmw}
base=configs/landing_95ghz.yaml
declare -A pos=([1000]="[0, -997.56, 69.76]" [400]="[0, -399.03, 27.90]")
declare -A weather=(
  [cloudy]='[]'
  [heavyfog]='[{kind: fog, base: 0 m, top: 600 m, liquid_water: 0.3 g/m3}]'
  [extremefog]='[{kind: fog, base: 0 m, top: 600 m, liquid_water: 1.0 g/m3}]'
)
for f in 35 95; do
  for r in 1000 400; do
    for w in cloudy heavyfog extremefog; do
      for style in plate brackets; do
        name="${f}ghz_${r}m_${w}_${style}"
        "$PMMW" render "$base" --out "out/landing/$name" \
          --set name="landing_$name" --set frequency="$f GHz" \
          --set imager.position="${pos[$r]}" --set atmosphere.layers="${weather[$w]}" \
          --set scene[0].mesh="../scenes/landing/landing_${style}.glb" "$@"
      done
    done
  done
done
