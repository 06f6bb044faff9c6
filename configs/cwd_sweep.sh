#!/usr/bin/env bash
# The concealed-weapon grid of Murakowski 2014 sec. 3.2 from the two base configs: outdoor/indoor x
# 35/95 GHz x 4 m (30 deg vertical field) / 20 m (6 deg) = 8 renders into out/cwd/<...>/.
# Extra pmmw options pass through, e.g. `configs/cwd_sweep.sh --workers 8 --quiet`.
set -euo pipefail
cd "$(dirname "$0")/.."
PMMW=${PMMW:-pmmw}
declare -A pos=([4]="[0, -4, 1.5]" [20]="[0, -20, 1.5]")
declare -A fov=([4]="18.1 deg" [20]="3.57 deg")
for place in outdoor indoor; do
  for f in 35 95; do
    for d in 4 20; do
      name="cwd_${place}_${f}ghz_${d}m"
      "$PMMW" render "configs/cwd_${place}_95ghz.yaml" --out "out/cwd/$name" --set name="$name" \
        --set frequency="$f GHz" --set imager.position="${pos[$d]}" --set imager.fov="${fov[$d]}" "$@"
    done
  done
done
