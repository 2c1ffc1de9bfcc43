#!/bin/bash
# Before/after comparison of `tprf nlos` outputs (capture, reconstruct, spad) on the
# built-in NLOS scenes and mitransient's nlos_Z.xml: run two tprf binaries on the same
# commands and compare every file bit for bit; JSON files with their timing fields
# (render_s, seconds) and the embedded request left out, stderr with its timings masked.
#
#   benches/nlos_ab.sh BEFORE_TPRF AFTER_TPRF [WORKDIR]
set -euo pipefail
B=$(realpath "$1"); A=$(realpath "$2"); W=${3:-$(mktemp -d)}
XML=$(realpath "$(dirname "$0")/../assets/mitsuba/mitransient/transient-nlos/nlos_Z.xml")
outputs() {
    local T=$1 D=$2
    rm -rf "$D"; mkdir -p "$D"; cd "$D"
    $T nlos builtin:nlos-z --grid 24x24 --spp 64 --out z_single 2> z_single.err
    $T nlos builtin:nlos-z --grid 16x16 --spp 32 --confocal --unwarped --out z_conf 2> z_conf.err
    $T nlos builtin:nlos-shapes --grid 8x8 --spp 16 --exhaustive --laser-grid 3x2 --bins 400 --dt 5mm --t0 0.5m --out s_exh 2> s_exh.err
    $T nlos builtin:nlos-shapes --grid 12x10 --spp 16 --laser-point 0.2,0.1,0 --laser-origin=-0.4,0.1,0.5 --sensor-origin 0.3,0,0.4 --max-bounces 2 --channel red --seed 3 --out s_pt 2> s_pt.err
    $T nlos "$XML" --grid 16x16 --spp 32 --out xml 2> xml.err
    $T nlos "$XML" --spp 8 --out xml_default 2> xml_default.err
    for m in bp fbp fk pf; do $T nlos reconstruct z_conf --method $m --out rec_$m 2> rec_$m.err; done
    $T nlos reconstruct z_single --method fbp --volume 0,0,1:1.5,1.5,1:12,12,10 --wavelength 5cm --out rec_vol 2> rec_vol.err
    $T nlos spad z_conf --preset builtin:spad --seed 2 --out spad 2> spad.err
}
outputs "$B" "$W/before" >/dev/null
outputs "$A" "$W/after" >/dev/null
cd "$W/before"
bad=0; n=0
mask() { sed -E 's/[0-9.]+ s \(/T s (/; s/in [0-9.]+ s/in T s/' "$1"; }
for f in $(find . -type f | sort); do
    n=$((n + 1))
    case $f in
    *.json)
        python3 - "$W/before/$f" "$W/after/$f" <<'PY' || bad=1
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:])
for d in (a, b):
    for k in ("render_s", "seconds", "request"):
        d.pop(k, None)
if a != b:
    print("differs:", sys.argv[1]); sys.exit(1)
PY
        ;;
    *.err) diff <(mask "$W/before/$f") <(mask "$W/after/$f") > /dev/null || { echo "differs: $f"; bad=1; } ;;
    *) cmp -s "$W/before/$f" "$W/after/$f" || { echo "differs: $f"; bad=1; } ;;
    esac
done
echo "$n files compared in $W: $([ $bad = 0 ] && echo 'all the same' || echo 'SOME DIFFER')"
exit $bad
