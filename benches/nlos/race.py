#!/usr/bin/env python3
"""The NLOS race: a confocal capture of builtin:nlos-z, tprf against mitransient 1.3's
`transient_nlos_path` (laser sampling + hidden-geometry sampling, tal's "single corner"
configuration), at equal cube error, on the same CPU threads.

1. Twins. tprf renders `tprf nlos builtin:nlos-z --confocal --unwarped`; mitransient renders
   the same scene from a Mitsuba dict: tal's quickstart (a 2 x 2 m `rectangle` relay wall,
   tal's Z (`builtin:nlos-z`'s six triangles, as an OBJ) 1 m in front, both `diffuse`
   reflectance 1), a `projector` laser and an `nlos_capture_meter` at tal's device
   position (-0.5, 0, 0.25), `capture_type: confocal` (one mi.render call scans the whole
   grid, the laser at each scanned point), `transient_hdr_film` with the same bins,
   `bin_width_opl` and `start_opl` as tprf's `--dt`/`--t0` in metres, times unwarped
   (`account_first_and_last_bounces` false in both). `--bounces three` (default):
   mitransient's "single corner" configuration, tal's recommended one (hidden-geometry
   sampling without the relay wall, `max_depth` -1), which renders three-bounce paths
   only (measured: its cube equals that of `max_depth` 4 to the last digit), against
   tprf `--max-bounces 1`; `--bounces all`: mitransient with the relay wall in its
   hidden-geometry sampling against tprf's default (all bounces). Where tal is installed (`--tal-python`)
   tal's `read_capture` reads tprf's nlos.hdf5 and the script checks its H shape
   [T, Sx, Sy], delta_t, t_start and the unwarped flag against mitransient's film.
2. Units. mitransient's laser is a projector whose on-axis weight at distance d is
   pi E / d^2 (E its `irradiance`, 1 here: pi at 1 m, measured by the script from
   the emitter itself), and it lights the wall point l with irradiance that times
   cos(theta_l); tprf's H is per joule landing on l. So mitransient's H at wall point l
   is tprf's times w(l) = pi cos(theta_l) / |device - l|^2, a known per-point factor the
   script divides out (it costs nothing in the race). Its film rows are the wall's y,
   columns x; tprf's H is [T, Sx, Sy]: points are matched by their positions.
3. Twin check at --twin-spp, two seeds each: relative L2 of the difference of the two
   means against their two-seed noise (|diff|^2 / (var_t + var_m) ~ 1 when they agree),
   the per-point sum ratio, the mean arrival bin per wall point (its rms difference
   against its two-seed noise), and the first lit bin per wall point against the
   analytic first return 2 min|s - Z| / dt (exact point-triangle distances): no render
   has light before it, and the median over points of each mean's first lit bin is at
   most one bin after it (a point's closest patch is a small target for any sampler,
   so single points may light up later at low spp). It stops with a message if they disagree
   (--ignore-twin-check races anyway).
4. Reference: the twin check's four renders combined with inverse-variance weights (each
   renderer's variance from its two seeds); its own error is printed and subtracted in
   quadrature from the race's errors.
5. Race: spp = 1, 2, 4, ... for both, interleaved (the order alternates), new seeds, each
   until its cube error <= the smallest target or a run takes over --cap s. Cube error =
   ||H - ref|| / ||ref|| over [T, Sx, Sy]. Timed: tprf's whole `tprf nlos` process (start,
   scene, capture, writing nlos.hdf5/H.npy/nlos.json); mitransient's mi.render plus
   reading the tensor back, less Dr.Jit's kernel compilation (race.py's rule: a warm
   kernel cache). Time to 10 %, 5 %, 2 % by log-log interpolation (race.py's time_to) and
   the ratio mitransient / tprf (> 1: tprf is sooner).

Writes --out (default out/nlos-race): race.csv (one row per run, with the load average),
summary.json, summary.md. --quick: a 8 x 8 grid, few samples (< 2 min): does it all work?

Run it with the Python that has mitsuba + mitransient (e.g. target/race-venv/bin/python,
see benches/race/README.md); prints "skipped: ..." and exits 0 where it cannot import them.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]

def _camera_race():
    """benches/race/race.py (the camera race) as a module: its helpers (load_mitsuba, the
    statistics, time_to, the machine line) are this race's too."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("camera_race", REPO / "benches" / "race" / "race.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["camera_race"] = mod  # its dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


camera_race = _camera_race()

np = camera_race.np
DEVICE = (-0.5, 0.0, 0.25)  # tal's default laser and SPAD position
# builtin:nlos-z's Z (crates/tprf-core/src/scene/builtin.rs, tal's Z.obj), plane z = 1 m.
Z_DEPTH_M = 1.0
Z_TRIANGLES = [
    [(0.364878, 0.296774), (-0.4, 0.4), (0.364878, 0.4)],
    [(0.364878, 0.296774), (-0.164553, 0.296774), (-0.4, 0.4)],
    [(-0.164553, 0.296774), (0.164553, -0.296774), (-0.4, 0.4)],
    [(0.4, -0.4), (0.164553, -0.296774), (-0.164553, 0.296774)],
    [(0.4, -0.4), (-0.4, -0.296774), (0.164553, -0.296774)],
    [(0.4, -0.4), (-0.4, -0.4), (-0.4, -0.296774)],
]
TARGETS = (0.10, 0.05, 0.02)
log = camera_race.log


def write_z_obj(path: Path):
    """The Z as an OBJ, each triangle wound to face the wall (-z), as builtin:nlos-z."""
    lines = []
    for t in Z_TRIANGLES:
        p = [np.array([x, y, Z_DEPTH_M]) for x, y in t]
        if np.cross(p[1] - p[0], p[2] - p[0])[2] > 0:
            p = [p[0], p[2], p[1]]
        lines += [f"v {q[0]} {q[1]} {q[2]}" for q in p]
    lines += [f"f {3 * i + 1} {3 * i + 2} {3 * i + 3}" for i in range(len(Z_TRIANGLES))]
    path.write_text("\n".join(lines) + "\n")


def mitsuba_dict(mi, obj: Path, grid, bins, dt_m, t0_m, all_bounces):
    """tal's quickstart as a Mitsuba dict. all_bounces False: mitransient's "single corner"
    configuration (hidden-geometry sampling without the relay wall: three-bounce paths
    only, whatever max_depth); True: its "higher-order bounces" one (the wall included)."""
    return {
        "type": "scene",
        "integrator": {
            "type": "transient_nlos_path",
            "nlos_laser_sampling": True,
            "nlos_hidden_geometry_sampling": True,
            "nlos_hidden_geometry_sampling_includes_relay_wall": all_bounces,
            "temporal_filter": "box",
            "capture_type": "confocal",
            "max_depth": -1,
            "block_size": 1,
            "account_first_and_last_bounces": False,
        },
        "laser": {
            "type": "projector",
            "irradiance": 1.0,
            "fov": 0.2,  # tal's, with laser sampling
            "to_world": mi.ScalarTransform4f().look_at(origin=DEVICE, target=[0, 0, 0], up=[0, 1, 0]),
        },
        "z": {"type": "obj", "filename": str(obj), "bsdf": {"type": "diffuse", "reflectance": 1.0}},
        "relay_wall": {
            "type": "rectangle",
            "bsdf": {"type": "diffuse", "reflectance": 1.0},
            "sensor": {
                "type": "nlos_capture_meter",
                "sensor_origin": list(DEVICE),
                "sampler": {"type": "independent", "sample_count": 1},
                "film": {
                    "type": "transient_hdr_film",
                    "width": grid,
                    "height": grid,
                    "temporal_bins": bins,
                    "bin_width_opl": dt_m,
                    "start_opl": t0_m,
                    "rfilter": {"type": "box"},
                },
            },
        },
    }


class Run:
    def __init__(self, who, spp, seed, cube, wall_s, raw_s, compile_s=0.0, inner_s=None):
        self.who, self.spp, self.seed, self.cube = who, spp, seed, cube
        self.wall_s, self.raw_s, self.compile_s, self.inner_s = wall_s, raw_s, compile_s, inner_s


class Tprf:
    name = "tprf"

    def __init__(self, exe, work: Path, grid, bins, dt_m, t0_m, threads, all_bounces):
        self.exe, self.work = exe, work
        self.args = ["nlos", "builtin:nlos-z", "--confocal", "--unwarped", "--grid", f"{grid}x{grid}",
                     "--bins", str(bins), "--dt", f"{dt_m:.9f}m", "--t0", f"{t0_m:.9f}m",
                     "--threads", str(threads)]
        if not all_bounces:
            self.args += ["--max-bounces", "1"]  # one hidden vertex: three-bounce paths
        self.meta = None

    def run(self, spp, seed) -> Run:
        out = self.work / "tprf-run"
        cmd = [str(self.exe), *self.args, "--spp", str(spp), "--seed", str(seed), "--out", str(out)]
        t0 = time.perf_counter()
        p = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if p.returncode != 0:
            raise SystemExit(f"tprf nlos failed ({' '.join(cmd)}):\n{p.stderr}")
        self.meta = json.loads((out / "nlos.json").read_text())
        cube = np.load(out / "H.npy").astype(np.float64)  # [T, Sx, Sy]
        return Run("tprf", spp, seed, cube, wall, wall, 0.0, self.meta.get("render_s"))

    def grid_xyz(self):
        """Sensor points [Sx, Sy, 3] from nlos.json's wall frame (cell centres)."""
        w = self.meta["wall"]
        nx, ny = self.meta["grid"]
        c, u, v = (np.array(w[k], dtype=np.float64) for k in ("corner", "u_axis", "v_axis"))
        i = (np.arange(nx) + 0.5) / nx * w["width_m"]
        j = (np.arange(ny) + 0.5) / ny * w["height_m"]
        return c + i[:, None, None] * u + j[None, :, None] * v


class Mitransient:
    name = "mitransient"

    def __init__(self, mi, dr, scene_dict, threads, max_lanes=1 << 23):
        self.mi, self.dr, self.max_lanes = mi, dr, max_lanes
        dr.set_thread_count(threads)
        dr.set_flag(dr.JitFlag.KernelHistory, True)
        self.scene = mi.load_dict(scene_dict)
        film = self.scene.sensors()[0].film()
        self.n = film.size().x
        # The projector's weight on its axis at 1 m: the laser's irradiance factor.
        e = self.scene.emitters()[0]
        it = dr.zeros(mi.Interaction3f)
        it.p = mi.Point3f(DEVICE) + e.world_transform() @ mi.Vector3f(0, 0, 1)
        _, w = e.sample_direction(it, mi.Point2f(0.5, 0.5))
        self.weight_at_1m = float(np.array(w).ravel()[0])
        self.to_tprf = None  # (index x, index y, per-point factor) once tprf's grid is known

    def match(self, grid_xyz):
        """Map mitransient's film pixels to tprf's sensor points by position, and the
        per-point factor w(l) = weight_at_1m cos(theta_l) / |device - l|^2 to divide out."""
        n = self.n
        gi = np.rint((grid_xyz[..., 0] + 1) / 2 * n - 0.5).astype(int)
        gj = np.rint((grid_xyz[..., 1] + 1) / 2 * n - 0.5).astype(int)
        centre = lambda k: (k + 0.5) / n * 2 - 1  # noqa: E731  (mitsuba's rectangle: uv -> 2uv - 1)
        if (gi.min() < 0 or gj.min() < 0 or gi.max() >= n or gj.max() >= n
                or np.abs(centre(gi) - grid_xyz[..., 0]).max() > 1e-5
                or np.abs(centre(gj) - grid_xyz[..., 1]).max() > 1e-5
                or np.abs(grid_xyz[..., 2]).max() > 1e-6):
            raise SystemExit("twin check failed: tprf's sensor grid is not mitransient's film lattice "
                             "on the wall z = 0 (cell centres of [-1, 1]^2)")
        d = np.array(DEVICE) - grid_xyz
        dist = np.linalg.norm(d, axis=-1)
        factor = self.weight_at_1m * (d[..., 2] / dist) / dist**2
        self.to_tprf = (gi, gj, factor)

    def run(self, spp, seed) -> Run:
        mi, dr = self.mi, self.dr
        # One mi.render holds grid^2 x spp lanes; large runs are split into calls of at
        # most max_lanes (equal spp, their own seeds) and averaged.
        chunks = max(1, math.ceil(self.n * self.n * spp / self.max_lanes))
        while spp % chunks:
            chunks += 1
        dr.kernel_history()
        t0 = time.perf_counter()
        tr = 0.0
        for k in range(chunks):
            _, part = mi.render(self.scene, spp=spp // chunks, seed=seed * 1009 + k)
            tr = tr + np.array(part, dtype=np.float64)[..., 0]  # [row = y, column = x, T]
        tr = tr / chunks
        wall = time.perf_counter() - t0
        compile_s = sum(k.get("codegen_time", 0.0) + k.get("backend_time", 0.0)
                        for k in dr.kernel_history() if k.get("cache_hit", 1) == 0) / 1e3
        gi, gj, factor = self.to_tprf
        cube = tr[gj, gi] / factor[..., None]  # [Sx, Sy, T], tprf's units
        cube = np.moveaxis(cube, -1, 0)
        return Run("mitransient", spp, seed, cube, max(wall - compile_s, 1e-6), wall, compile_s)


def mean_arrival(cube):
    """Per wall point, the centre of mass of its transient in bins ([T, Sx, Sy] ->
    [Sx, Sy]), and the mask of points with signal."""
    total = cube.sum(axis=0)
    bins = np.arange(cube.shape[0]) + 0.5
    with np.errstate(invalid="ignore", divide="ignore"):
        return (cube * bins[:, None, None]).sum(axis=0) / total, total > 0


def first_nonzero(cube):
    """Per wall point, its first bin with light ([T, Sx, Sy] -> [Sx, Sy]; T where none)."""
    lit = cube > 0
    return np.where(lit.any(axis=0), lit.argmax(axis=0), cube.shape[0])


def analytic_first_bin(grid_xyz, dt_m, t0_m):
    """Per wall point s, the bin of the shortest confocal path 2 |s - Z| (unwarped): the
    exact distance to the Z's triangles (in the plane z = Z_DEPTH_M, the wall z = 0):
    sqrt(depth^2 + the 2-D distance from s to the triangle)."""

    def seg(p, a, b):
        ab, ap = b - a, p - a
        t = np.clip((ap @ ab) / (ab @ ab), 0.0, 1.0)
        return np.linalg.norm(ap - t * ab)

    def tri(p, t):
        a, b, c = (np.array(q, dtype=np.float64) for q in t)
        cr = lambda u, v: u[0] * v[1] - u[1] * v[0]  # noqa: E731
        s = [cr(b - a, p - a), cr(c - b, p - b), cr(a - c, p - c)]
        if all(x >= 0 for x in s) or all(x <= 0 for x in s):
            return 0.0
        return min(seg(p, a, b), seg(p, b, c), seg(p, c, a))

    out = np.zeros(grid_xyz.shape[:2], dtype=int)
    for i in range(grid_xyz.shape[0]):
        for j in range(grid_xyz.shape[1]):
            p = grid_xyz[i, j]
            d2 = min(tri(p[:2], t) for t in Z_TRIANGLES)
            dist = math.sqrt((Z_DEPTH_M - p[2]) ** 2 + d2**2)
            # A path of exactly a bin edge (the wall points right in front of the Z: 2.000 m)
            # may land in the bin below in float32 (mitransient's): 1e-4 of a bin of slack.
            out[i, j] = math.floor((2 * dist - t0_m) / dt_m - 1e-4)
    return out


def tal_check(tal_python, capture: Path, bins, dt_m, t0_m, grid):
    """tal reads tprf's nlos.hdf5: its H and time axis are the ones mitransient renders."""
    code = ("import sys, json, numpy as np, tal\n"
            "d = tal.io.read_capture(sys.argv[1])\n"
            "print(json.dumps({'H': list(d.H.shape), 'delta_t': float(d.delta_t), 't_start': float(d.t_start),"
            " 'unwarped': not bool(d.t_accounts_first_and_last_bounces),"
            " 'grid': list(np.asarray(d.sensor_grid_xyz).shape), 'H_format': str(d.H_format)}))\n")
    if not tal_python or not Path(tal_python).exists():
        return {"skipped": f"no tal Python at {tal_python} (pip install y-tal h5py there)"}
    p = subprocess.run([tal_python, "-c", code, str(capture / "nlos.hdf5")], capture_output=True, text=True)
    if p.returncode != 0:
        return {"skipped": f"tal could not read the capture: {p.stderr.strip().splitlines()[-1:]}"}
    got = json.loads(p.stdout)
    want = {"H": [bins, grid, grid], "delta_t": dt_m, "t_start": t0_m, "unwarped": True}
    ok = (got["H"] == want["H"] and abs(got["delta_t"] - dt_m) < 1e-9 and abs(got["t_start"] - t0_m) < 1e-9
          and got["unwarped"])
    return {"ok": ok, "tal": got, "mitransient film": want}


def twin_check(tprf, mt, cfg, report):
    spp = cfg.twin_spp
    log(f"twin check: {spp} spp, seeds 1 and 2, both renderers")
    t = [tprf.run(spp, s) for s in (1, 2)]
    mt.match(tprf.grid_xyz())
    m = [mt.run(spp, s) for s in (1, 2)]
    for r in t + m:
        log(f"  {r.who:12s} seed {r.seed}: {r.wall_s:7.2f} s")
    tm, tv = camera_race.halves(t[0].cube, t[1].cube)
    mm, mv = camera_race.halves(m[0].cube, m[1].cube)
    chi, rel = camera_race.compare(tm, tv, mm, mv)
    ref_sq = camera_race.sq((tm + mm) / 2)
    at, mask = mean_arrival(tm)
    am, mask_m = mean_arrival(mm)
    mask &= mask_m
    for r in t + m:
        r.arrival = mean_arrival(r.cube)[0]
    dbin = np.abs(at - am)[mask]
    # The mean arrival's noise per point from each renderer's two seeds: var of a mean of
    # two = (x1 - x2)^2 / 4; the difference's squared mean over points against it.
    noise = ((t[0].arrival - t[1].arrival) ** 2 / 4 + (m[0].arrival - m[1].arrival) ** 2 / 4)[mask]
    arrival_chi = float(np.mean((at - am)[mask] ** 2) / max(np.mean(noise), 1e-12))
    first = analytic_first_bin(tprf.grid_xyz(), cfg.dt_m, cfg.t0_m)
    early = {r.who + f" seed {r.seed}": int((first - first_nonzero(r.cube)).max()) for r in t + m}
    late = {who: [int(np.median(first_nonzero(c) - first)), int((first_nonzero(c) - first).max())]
            for who, c in (("tprf", tm), ("mitransient", mm))}
    sums = mm.sum(axis=0) / np.where(tm.sum(axis=0) > 0, tm.sum(axis=0), np.nan)
    res = {
        "spp": spp,
        "rel_l2_difference": rel,
        "tprf_noise_rel": math.sqrt(tv / ref_sq),
        "mitransient_noise_rel": math.sqrt(mv / ref_sq),
        "chi2_per_noise": chi,
        "sum_ratio_mt_over_tprf": [float(np.nanmin(sums)), float(np.nanmedian(sums)), float(np.nanmax(sums))],
        "mean_arrival_max_bin_difference": float(dbin.max()) if dbin.size else None,
        "mean_arrival_rms_bin_difference": float(np.sqrt(np.mean(dbin**2))) if dbin.size else None,
        "mean_arrival_chi2_per_noise": arrival_chi,
        "light_before_the_first_return_bins": early,
        "first_lit_bin_after_analytic_max": late,
        "points_with_signal": int(mask.sum()),
        "laser_weight_at_1m": mt.weight_at_1m,
    }
    log(f"  relative L2 of the difference {rel:.4f}; noise (one mean) tprf {res['tprf_noise_rel']:.4f}, "
        f"mitransient {res['mitransient_noise_rel']:.4f}; |diff|^2 / (var_t + var_m) = {chi:.2f} (1: within noise)")
    log(f"  per-point sum mitransient / tprf: min {res['sum_ratio_mt_over_tprf'][0]:.4f}, median "
        f"{res['sum_ratio_mt_over_tprf'][1]:.4f}, max {res['sum_ratio_mt_over_tprf'][2]:.4f}; mean arrival: "
        f"rms difference {res['mean_arrival_rms_bin_difference']:.2f} bin, largest {res['mean_arrival_max_bin_difference']:.2f}, "
        f"against the two-seed noise {arrival_chi:.2f} (1: within noise) over {res['points_with_signal']} points")
    log(f"  first lit bin against the analytic first return 2 min|s - Z| / dt: earliest by {max(early.values())} "
        f"bins {early} (<= 0: no light before it); the means' first lit bin after it [median, max] {late} bins")
    report["twin"] = res
    ok = (chi < cfg.twin_chi and arrival_chi < cfg.twin_chi and max(early.values()) <= 0
          and max(v[0] for v in late.values()) <= 1)
    if not ok:
        msg = ("twin check FAILED: the two captures differ by more than their noise "
               f"(|diff|^2 / noise = {chi:.2f}, limit {cfg.twin_chi}) or the mean arrivals by more than a bin, or a first return is not at its analytic bin; "
               "look at units (the laser's pi cos / d^2), wall albedo, falloff, time axis")
        if not cfg.ignore_twin_check:
            raise SystemExit(msg)
        log("  " + msg + " (racing anyway: --ignore-twin-check)")
    # The reference: inverse-variance combination of the four renders.
    wt, wm = 1 / max(tv, 1e-300), 1 / max(mv, 1e-300)
    ref = (wt * tm + wm * mm) / (wt + wm)
    ref_var = 1 / (wt + wm)
    ref_err = math.sqrt(ref_var / camera_race.sq(ref))
    report["reference"] = {"how": f"tprf and mitransient at {spp} spp, two seeds each, inverse-variance weighted",
                           "own_error": ref_err}
    log(f"  reference: the four combined (inverse-variance); its own error {ref_err:.4f}")
    return ref, ref_err


def race(tprf, mt, ref, ref_err, cfg, report, csv_path: Path):
    rows, done = [], {"tprf": False, "mitransient": False}
    ref_sq = camera_race.sq(ref)
    spp, k = 1, 0
    while not all(done.values()) and spp <= cfg.max_spp:
        order = [tprf, mt] if k % 2 == 0 else [mt, tprf]
        for r in order:
            if done[r.name]:
                continue
            load = camera_race.loadavg()
            run = r.run(spp, 1000 + k)
            raw = math.sqrt(camera_race.sq(run.cube - ref) / ref_sq)
            err = math.sqrt(max(raw**2 - ref_err**2, 0.0))
            row = {"renderer": r.name, "spp": spp, "seed": run.seed, "wall_s": round(run.wall_s, 5),
                   "raw_wall_s": round(run.raw_s, 5), "compile_s": round(run.compile_s, 5),
                   "render_s": run.inner_s, "cube_error": err, "raw_cube_error": raw, "loadavg": load}
            rows.append(row)
            log(f"  {r.name:12s} {spp:6d} spp  {run.wall_s:8.3f} s  error {err:.4f}  (load {load})")
            if err <= min(cfg.targets) or run.wall_s > cfg.cap:
                done[r.name] = True
        spp *= 2
        k += 1
    with open(csv_path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    summary = []
    for target in cfg.targets:
        line = {"target": target}
        for who in ("tprf", "mitransient"):
            pts = [(r["wall_s"], r["cube_error"]) for r in rows if r["renderer"] == who]
            t, how = camera_race.time_to(pts, target)
            line[who] = t
            line[who + "_how"] = how
        line["ratio"] = line["mitransient"] / line["tprf"] if line["tprf"] and line["mitransient"] else None
        summary.append(line)
    report["race"] = rows
    report["summary"] = summary
    for who in ("tprf", "mitransient"):
        pts = [(r["wall_s"], r["cube_error"]) for r in rows if r["renderer"] == who]
        report.setdefault("tail_constant", {})[who] = camera_race.tail_constant(pts)
    return summary


def markdown(cfg, report):
    L = [f"# NLOS race: confocal builtin:nlos-z, {cfg.grid} x {cfg.grid} points, {cfg.bins} bins of "
         f"{cfg.dt_m * 1e3:g} mm, {cfg.bounces} bounces, {cfg.threads} threads each", "",
         f"{report['machine']}; {report['versions']}; load average at start {report['load_start']}, "
         f"at end {report.get('load_end', '?')}", ""]
    tw = report["twin"]
    L += [f"Twin check at {tw['spp']} spp (two seeds each): relative L2 difference {tw['rel_l2_difference']:.4f}, "
          f"noise of each mean tprf {tw['tprf_noise_rel']:.4f}, mitransient {tw['mitransient_noise_rel']:.4f}, "
          f"|diff|^2 / noise {tw['chi2_per_noise']:.2f}; mean arrival per point: rms difference "
          f"{tw['mean_arrival_rms_bin_difference']:.2f} bin (against its noise {tw['mean_arrival_chi2_per_noise']:.2f}); "
          + (f"light before the analytic first return by up to {max(early.values())} bins {early}"
             if max((early := tw['light_before_the_first_return_bins']).values()) > 0
             else "no light before the analytic first return")
          + f", the first lit bin after it [median, max]: "
          f"{tw['first_lit_bin_after_analytic_max']}; per-point sum ratio (median) "
          f"{tw['sum_ratio_mt_over_tprf'][1]:.4f}.", "",
          f"Reference: {report['reference']['how']}; own error {report['reference']['own_error']:.4f}.", "",
          "| cube error | tprf (s) | mitransient (s) | mitransient / tprf |", "| --- | --- | --- | --- |"]
    for s in report["summary"]:
        f = lambda who: (f"{s[who]:.3f}" + (" (fit)" if s[who + '_how'] == 'fit' else "")) if s[who] else "-"  # noqa: E731
        L.append(f"| {s['target'] * 100:g} % | {f('tprf')} | {f('mitransient')} | "
                 f"{s['ratio']:.2f}x |" if s["ratio"] else f"| {s['target'] * 100:g} % | {f('tprf')} | {f('mitransient')} | - |")
    return "\n".join(L) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="8 x 8 grid, few samples (< 2 min)")
    ap.add_argument("--grid", type=int, default=16)
    ap.add_argument("--bins", type=int, default=450, help="with --dt-m, reaches 4.5 m of path (the Z's longest three-bounce path is 4.44 m)")
    ap.add_argument("--dt-m", type=float, default=0.01,
                    help="bin width, metres of optical path (tal's default is 3 mm: 3.3x the bins, so 3.3x the samples to each error)")
    ap.add_argument("--t0-m", type=float, default=0.0)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--bounces", choices=("three", "all"), default="three",
                    help="three: tprf --max-bounces 1 against mitransient's single-corner configuration "
                    "(tal's recommended one; it renders three-bounce paths only); all: tprf's default "
                    "against mitransient with the relay wall in its hidden-geometry sampling")
    ap.add_argument("--twin-spp", type=int, default=1 << 17,
                    help="spp of the twin check's renders (two seeds each), which make the reference too")
    ap.add_argument("--twin-chi", type=float, default=2.0, help="largest |diff|^2 / noise accepted")
    ap.add_argument("--ignore-twin-check", action="store_true")
    ap.add_argument("--max-spp", type=int, default=1 << 17)
    ap.add_argument("--cap", type=float, default=60.0, help="stop a renderer after a run this long (s)")
    ap.add_argument("--tprf", help="tprf binary (default target/release/tprf)")
    ap.add_argument("--tal-python", default=str(REPO / "target" / "nlos-venv" / "bin" / "python"),
                    help="a Python with y-tal and h5py, to read tprf's nlos.hdf5 with tal")
    ap.add_argument("--out", default=str(REPO / "out" / "nlos-race"))
    cfg = ap.parse_args(argv)
    if cfg.quick:
        cfg.grid, cfg.twin_spp, cfg.max_spp = 8, 8192, 4096
    cfg.targets = TARGETS
    if np is None:
        print("skipped: numpy is not installed")
        return 0
    loaded, why = camera_race.load_mitsuba()
    if loaded is None:
        why = why.replace("or run with --setup", "(benches/race/README.md: Install)")
        print(f"skipped: {why}")
        return 0
    mi, dr, versions = loaded
    exe = camera_race.find_tprf(cfg.tprf)
    if not exe.exists():
        raise SystemExit(f"no tprf binary at {exe}: cargo build --release --bin tprf, or --tprf PATH")
    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    report = {"settings": {k: v for k, v in vars(cfg).items()}, "versions": versions,
              "machine": camera_race.machine_line(), "load_start": camera_race.loadavg()}
    log(f"{report['machine']}; load {report['load_start']}")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        obj = work / "z.obj"
        write_z_obj(obj)
        every = cfg.bounces == "all"
        tprf = Tprf(exe, work, cfg.grid, cfg.bins, cfg.dt_m, cfg.t0_m, cfg.threads, every)
        mt = Mitransient(mi, dr, mitsuba_dict(mi, obj, cfg.grid, cfg.bins, cfg.dt_m, cfg.t0_m, every), cfg.threads)
        ref, ref_err = twin_check(tprf, mt, cfg, report)
        report["tal"] = tal_check(cfg.tal_python, work / "tprf-run", cfg.bins, cfg.dt_m, cfg.t0_m, cfg.grid)
        log(f"tal's reader on tprf's capture: {report['tal']}")
        if report["tal"].get("ok") is False:
            raise SystemExit("twin check failed: tal reads a different H shape or time axis than mitransient's film")
        log("race: spp 1, 2, 4, ... interleaved")
        race(tprf, mt, ref, ref_err, cfg, report, out / "race.csv")
    report["load_end"] = camera_race.loadavg()
    (out / "summary.json").write_text(json.dumps(report, indent=1, default=str))
    md = markdown(cfg, report)
    (out / "summary.md").write_text(md)
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
