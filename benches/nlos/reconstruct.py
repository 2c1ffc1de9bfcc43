#!/usr/bin/env python3
"""tprf's NLOS reconstruction against tal's own, side by side on one capture.

Renders a confocal capture of builtin:nlos-z with `tprf nlos` (or takes --capture DIR),
then for each method reconstructs the same voxels with `tprf nlos reconstruct` and with
tal (pip's y-tal: `tal.reconstruct.bp`, `.fbp`, `.pf` (confocal; `.pf_dev` otherwise) and `.fk`), both on the same
number of CPU processes, and prints the wall times, the ratio tal / tprf (> 1: tprf is
faster) and how well the two volumes agree (correlation of the magnitudes, peak voxels).

tprf's time is the whole command (reading nlos.hdf5, reconstructing, writing volume.npy,
volume.json and the projections); tal's is its solve call alone, after read_capture.

    python3 benches/nlos/reconstruct.py                  # 64 x 64 capture, 64^3 voxels
    python3 benches/nlos/reconstruct.py --grid 32 --voxels 32

Needs a Python with y-tal and h5py (`--python`, default target/nlos-venv/bin/python,
which tests/nlos.rs makes) and a release build of tprf (`--tprf`).
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

TAL_SCRIPT = r"""
import sys, json, time, numpy as np, tal
from tal.enums import CameraSystem
cap, method, vol_json, wl, procs, ours = sys.argv[1:7]
tal.set_resources(cpu_processes=int(procs))
tal.set_log_level(tal.LogLevel.ERROR) if hasattr(tal, 'set_log_level') else None
vol = json.loads(vol_json); wl = float(wl)
data = tal.io.read_capture(cap)
c, s, n = np.array(vol['center']), vol['size_m'], vol['voxels']
u, v, w = np.array(vol['u']), np.array(vol['v']), np.array(vol['n'])
f = lambda k: ((np.arange(n[k]) + 0.5) / n[k] - 0.5) * s[k]
X, Y, Z = np.meshgrid(f(0), f(1), f(2), indexing='ij')
xyz = (c + X[..., None] * u + Y[..., None] * v + Z[..., None] * w).astype(np.float32)
start = time.perf_counter()
if method == 'bp':
    R = tal.reconstruct.bp.solve(data, volume_xyz=xyz, camera_system=CameraSystem.DIRECT_LIGHT, progress=False)
elif method == 'fbp':
    R = tal.reconstruct.fbp.solve(data, wl_mean=wl, wl_sigma=wl / np.sqrt(2), volume_xyz=xyz,
                                  camera_system=CameraSystem.DIRECT_LIGHT, progress=False)
elif method == 'pf' and data.is_laser_paired_to_sensor():
    # pf_dev refuses confocal captures; tal's pf takes them (sigma = cycles wl / 6).
    R = tal.reconstruct.pf.solve(data, wl, 6 / np.sqrt(2), camera_system=CameraSystem.DIRECT_LIGHT, volume=xyz)
elif method == 'pf':
    R = tal.reconstruct.pf_dev.solve(data, wl_mean=wl, wl_sigma=wl / np.sqrt(2), volume_xyz=xyz,
                                     camera_system=CameraSystem.DIRECT_LIGHT, progress=False)
elif method == 'fk':
    R = tal.reconstruct.fk.solve(data)
seconds = time.perf_counter() - start
R = np.abs(np.asarray(R))
O = np.load(ours)  # [Z, Y, X]
if method == 'fk':
    # tal's fk volume is its own [depth bin, y?, x?] lattice: compare peaks only.
    print(json.dumps({'seconds': seconds, 'correlation': None}))
    sys.exit(0)
O = O.transpose(2, 1, 0)
a, b = R.ravel() / R.max(), O.ravel() / O.max()
corr = float(np.dot(a - a.mean(), b - b.mean()) / np.linalg.norm(a - a.mean()) / np.linalg.norm(b - b.mean()))
print(json.dumps({'seconds': seconds, 'correlation': corr,
                  'tal_peak': [int(x) for x in np.unravel_index(R.argmax(), R.shape)],
                  'tprf_peak': [int(x) for x in np.unravel_index(O.argmax(), O.shape)]}))
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    target = os.environ.get('CARGO_TARGET_DIR', os.path.join(ROOT, 'target'))
    ap.add_argument('--tprf', default=os.path.join(target, 'release', 'tprf'))
    ap.add_argument('--python', default=os.path.join(target, 'nlos-venv', 'bin', 'python'))
    ap.add_argument('--capture', help='a tprf nlos folder (default: render one)')
    ap.add_argument('--grid', type=int, default=64)
    ap.add_argument('--spp', type=int, default=64)
    ap.add_argument('--voxels', type=int, default=64)
    ap.add_argument('--threads', type=int, default=2)
    ap.add_argument('--methods', default='bp,fbp,pf,fk')
    a = ap.parse_args()
    check = subprocess.run([a.python, '-c', 'import tal, h5py'], capture_output=True)
    if check.returncode != 0:
        print(f'skipped: {a.python} cannot import tal and h5py (pip install y-tal h5py)')
        return 0
    work = tempfile.mkdtemp(prefix='tprf-nlos-bench-')
    cap = a.capture
    if cap is None:
        cap = os.path.join(work, 'capture')
        subprocess.run([a.tprf, 'nlos', 'builtin:nlos-z', '--confocal', '--unwarped',
                        '--grid', f'{a.grid}x{a.grid}', '--spp', str(a.spp),
                        '--threads', str(a.threads), '--out', cap], check=True)
    meta = json.load(open(os.path.join(cap, 'nlos.json')))
    # The wall's frame: the volume centred on the grid, from 0.5 m to 1.5 m in front.
    n = meta['wall']['normal']
    center = [sum(x) for x in zip(*[[meta['wall']['corner'][i] + 0.5 * meta['wall']['width_m'] * meta['wall']['u_axis'][i]
                                     + 0.5 * meta['wall']['height_m'] * meta['wall']['v_axis'][i] for i in range(3)],
                                    [n[i] * 1.0 for i in range(3)]])]
    size = [meta['wall']['width_m'], meta['wall']['height_m'], 1.0]
    vox = [a.voxels] * 3
    volume = ','.join(map(str, center)) + ':' + ','.join(map(str, size)) + ':' + ','.join(map(str, vox))
    rows = []
    for method in a.methods.split(','):
        out = os.path.join(work, method)
        t = time.perf_counter()
        subprocess.run([a.tprf, 'nlos', 'reconstruct', cap, '--method', method, '--volume', volume,
                        '--threads', str(a.threads), '--out', out], check=True, capture_output=True)
        tprf_s = time.perf_counter() - t
        vol = json.load(open(os.path.join(out, 'volume.json')))
        wl = (vol.get('wave') or {}).get('wavelength_m') or 4 * size[0] / a.grid
        r = subprocess.run([a.python, '-c', TAL_SCRIPT, os.path.join(cap, 'nlos.hdf5'), method,
                            json.dumps(vol['volume']), str(wl), str(a.threads),
                            os.path.join(out, 'volume.npy')], capture_output=True, text=True)
        if r.returncode != 0:
            print(f'{method}: tal failed:\n{r.stderr[-2000:]}')
            continue
        tal = json.loads(r.stdout.strip().splitlines()[-1])
        rows.append((method, tprf_s, tal['seconds'], tal.get('correlation'), tal.get('tal_peak'), tal.get('tprf_peak')))
    print(f'\ncapture {a.grid}x{a.grid} confocal, volume {a.voxels}^3 voxels, {a.threads} CPU processes each')
    print('| method | tprf (s, whole command) | tal (s, solve only) | tal / tprf | correlation | peak tal / tprf [x, y, z] |')
    print('| --- | --- | --- | --- | --- | --- |')
    for m, ts, ls, corr, pt, po in rows:
        c = '-' if corr is None else f'{corr:.4f}'
        print(f'| {m} | {ts:.2f} | {ls:.2f} | {ls / ts:.1f}x | {c} | {pt} / {po} |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
