#!/bin/sh
# Regenerates the figures and tables of docs/accuracy.md: one convergence run per
# reference (the default estimator for 60 s, alternatives for 20 s each) and the
# stability table. About 9 minutes on 2 cores.
#
#   sh docs/accuracy/regenerate.sh
set -e
cd "$(dirname "$0")/../.."
cargo build --release --quiet
tprf() { cargo run --release --quiet -- "$@"; }
out=docs/accuracy
alt=seconds=20

tprf converge --reference 'analytic:furnace?rho=0.5' --seconds 60 --out $out/furnace-0.5 \
    --setting default --setting "filter=tent,$alt"
tprf converge --reference 'analytic:furnace?rho=0.9' --seconds 60 --out $out/furnace-0.9 \
    --setting default --setting "rr_floor=1,$alt" --setting "rr_start=0,$alt"
tprf converge --reference 'analytic:furnace?rho=0.99' --seconds 60 --out $out/furnace-0.99 \
    --setting default --setting "rr_floor=1,$alt"
tprf converge --reference 'analytic:furnace?rho=0.9&light=area' --seconds 30 \
    --out $out/furnace-area-0.9 --setting default --setting nee=off
tprf converge --reference analytic:plane --seconds 60 --out $out/plane \
    --setting default --setting "filter=tent,$alt"
tprf converge --reference analytic:oned --seconds 60 --out $out/oned \
    --setting default --setting "rr_floor=1,$alt"
tprf stability --out $out/stability
