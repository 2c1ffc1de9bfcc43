"""Render a Mitsuba XML scene with mitransient, for tests/mitsuba_mitransient.rs.

    python mitsuba_mitransient.py check
    python mitsuba_mitransient.py render SCENE.xml OUT_DIR WIDTH HEIGHT SPP SEED...
    python mitsuba_mitransient.py phasor SCENE.xml OUT_DIR WIDTH HEIGHT SPP SEED...

`check` exits 0 when mitsuba (its llvm_ad_mono variant) and mitransient load, else
prints why and exits 3. `render` loads the file as mitransient's users do
(`mi.load_file`, the film's width and height overridden through Mitsuba's
`<default>` parameters where the file has them, else by loading the film at its own size
and failing), renders it once per seed and writes OUT_DIR/mt_SEED_cube.npy (float32
[H, W, T], the transient film's one channel) and OUT_DIR/mt_SEED_steady.npy (float32
[H, W]: mitransient's steady image, every arrival time). `phasor` renders a file with a
`phasor_hdr_film` and writes OUT_DIR/mt_SEED_phasor.npy (float32 [H, W, F, 2], real and
imaginary: the film's developed phasors).
"""

import os
import sys

LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"


def load():
    if "DRJIT_LIBLLVM_PATH" not in os.environ and os.path.exists(LLVM):
        os.environ["DRJIT_LIBLLVM_PATH"] = LLVM
    import numpy as np
    import mitsuba as mi

    mi.set_variant("llvm_ad_mono")
    import drjit as dr
    import mitransient  # noqa: F401  (registers transient_path, transient_hdr_film)

    dr.set_thread_count(int(os.environ.get("MITRANSIENT_THREADS", "2")))
    fix_angulararea(mi, dr)
    return np, mi


def fix_angulararea(mi, dr):
    """mitransient 1.3.1's `angulararea` weighs its emitter samples by the squared
    distance twice: `sample_direction` returns radiance * falloff / dist^2 / ds.pdf, and
    ds.pdf is already a solid-angle density (the shape's, dist^2 / cos over its area), so
    next-event estimates are 1 / dist^2 too dark (the BSDF-sampled hits, `eval`, are
    right): with its cutoff and beam at 89.9 degrees it renders 3.2x darker than `area`
    on its own example. Re-registered here with that one factor removed (and
    `eval_direction` returning the radiance times the profile, as `area`'s), so the
    comparison is with mitransient's definition of the emitter."""
    from mitransient.emitters.angulararea import AngularAreaLight

    class FixedAngularAreaLight(AngularAreaLight):
        def sample_direction(self, ref, sample, active):
            ds = self.get_shape().sample_direction(ref, sample, active)
            active &= (dr.dot(ds.d, ds.n) < 0.0) & (ds.pdf != 0.0)
            si = mi.SurfaceInteraction3f(ds, ref.wavelengths)
            falloff = self._fallof_curve(mi.Frame3f(ds.n).to_local(-ds.d))
            active &= falloff > 0.0
            spec = self.radiance.eval(si, active) * falloff / ds.pdf
            ds.emitter = mi.EmitterPtr(self)
            return ds, dr.select(active, spec, 0.0)

        def eval_direction(self, ref, ds, active):
            active &= dr.dot(ds.d, ds.n) < 0.0
            falloff = self._fallof_curve(mi.Frame3f(ds.n).to_local(-ds.d))
            active &= falloff > 0.0
            si = mi.SurfaceInteraction3f(ds, ref.wavelengths)
            return dr.select(active, self.radiance.eval(si, active) * falloff, 0.0)

    mi.register_emitter("angulararea", lambda props: FixedAngularAreaLight(props))


def main(argv):
    if argv[:1] == ["check"]:
        try:
            load()
        except Exception as e:  # noqa: BLE001
            print(f"{type(e).__name__}: {e}")
            return 3
        return 0
    phasor = argv[:1] == ["phasor"]
    xml, out, width, height, spp, *seeds = argv[1:]
    np, mi = load()
    # Only the parameters the file declares (Mitsuba refuses others): mitransient's
    # examples name the film size `res` where they let it be changed.
    with open(xml) as f:
        text = f.read()
    params = {k: int(v) for k, v in (("res", width), ("spp", spp))
              if f'<default name="{k}"' in text}
    scene = mi.load_file(xml, **params)
    size = scene.sensors()[0].film().size()
    if (size.x, size.y) != (int(width), int(height)):
        raise SystemExit(f"{xml}: film {size.x} x {size.y}, asked {width} x {height}")
    for seed in seeds:
        steady, cube = mi.render(scene, spp=int(spp), seed=int(seed))
        if phasor:
            # phasor_hdr_film: [H, W, F, 2] (real, imaginary), already divided by spp.
            cube = np.array(cube, dtype=np.float32)
            np.save(os.path.join(out, f"mt_{seed}_phasor.npy"), np.ascontiguousarray(cube))
            continue
        cube = np.array(cube, dtype=np.float32)[..., 0]
        steady = np.array(steady, dtype=np.float32)[..., 0]
        np.save(os.path.join(out, f"mt_{seed}_cube.npy"), np.ascontiguousarray(cube))
        np.save(os.path.join(out, f"mt_{seed}_steady.npy"), np.ascontiguousarray(steady))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
