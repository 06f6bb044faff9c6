#!/usr/bin/env bash
# The landing scenario grid of seed 000 sec. 3.1 from one base config: 2 frequencies x 2 ranges
# x 3 weathers x 2 beacon styles = 24 renders into out/landing/<f>_<range>_<weather>_<style>/.
# Weathers (Table 3.2): cloudy (no fog; a cloud deck aloft), heavy fog 0.3 g/m3, extreme fog
# 1 g/m3 (fog from the ground to 600 m). Pass extra pmmw options after the script name,
# e.g. `configs/landing_sweep.sh --workers 8 --quiet`.
set -euo pipefail
cd "$(dirname "$0")/.."
PMMW=${PMMW:-pmmw}
base=configs/landing_95ghz.yaml
declare -A pos=([1000]="[0, -997.56, 69.76]" [400]="[0, -399.03, 27.90]")
declare -A weather=(
  [cloudy]='[{kind: cloud, base: 1000 m, top: 2000 m, liquid_water: 0.5 g/m3}]'
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
