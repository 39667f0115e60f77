#!/usr/bin/env bash
# How the sample tests were made (re-running this rewrites them identically: seeded).
set -euo pipefail
cd "$(dirname "$0")"
common="--df 1 --fmax 3200 --bungee-k 150 --sensor-mass-g 3 --noise-pct 0.5"
# The paper's stepped birch bat as the paper models it (Euler-Bernoulli, isotropic), measured
# with a 3 g accelerometer on bungees; then corked: 1 in core 10 in deep, 9 in cork, 1 in plug.
batlab simulate --profile paper_bat/profile.csv --meta paper_bat/meta.json \
  --beam euler --e-over-g 2.6 $common --seed 1 --out paper_bat/baseline.uff
batlab simulate --profile paper_bat/profile.csv --meta paper_bat/meta.json \
  --beam euler --e-over-g 2.6 $common --seed 2 --alter cork:depth=10,d=1.0,ratio=0.3333 \
  --out paper_bat/corked.uff
# A smooth-profile ash bat (34 in) as wood really is: 4 % stiffer and 3 % lighter than the
# handbook, E/G = 13, Timoshenko; baseline, then a re-test weeks later: moisture +0.8 points,
# accelerometer re-mounted 0.05 in away, and corked (1 in core, 10 in deep, fill 0.3).
batlab simulate --profile smooth_bat/profile.csv --meta smooth_bat/meta.json \
  --E-scale 1.04 --density-scale 0.97 --e-over-g 13 $common --seed 3 --out smooth_bat/baseline.uff
batlab simulate --profile smooth_bat/profile.csv --meta smooth_bat/meta.json \
  --E-scale 1.04 --density-scale 0.97 --e-over-g 13 $common --seed 4 --moisture 0.8 --sensor-offset-in 0.05 \
  --alter cork:depth=10,d=1.0,ratio=0.3 --out smooth_bat/retest_corked.uff
