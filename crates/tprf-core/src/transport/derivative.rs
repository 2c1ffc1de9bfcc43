//! Differentiable transient rendering: the vector-Jacobian product
//! `dL/dtheta = sum_{pixel, bin} weights[pixel, bin] d cube[pixel, bin] / dtheta` of a
//! cube with respect to scene parameters `theta` (a material's albedo or emission, a
//! pulsed light's intensity), for `L = sum(weights x cube)` with the caller's weights.
//!
//! # Method
//!
//! Forward-mode derivatives along each path with detached sampling (the estimator of
//! path replay backpropagation, Vicini, Speierer & Jakob 2021, "Path Replay
//! Backpropagation", with pdfs, MIS weights and roulette probabilities treated as
//! constants). Beside its throughput `T`, a path carries `dT_k = dT/dtheta_k` for the
//! `K` parameters asked for. Where `T` is multiplied by a sample weight `f |cos| / p`,
//! the product rule gives `dT_k <- dT_k f |cos| / p + T (df/dtheta_k) |cos| / p`; a
//! contribution `c = T g` (g: the light's or emitter's term) adds `dT_k g + T dg/dtheta_k`
//! times the caller's weight of the bin `c` lands in. Memory is `K` floats per path,
//! whatever its length, and no path is stored or replayed: the derivative is carried
//! forward instead of propagated back, which for a scalar loss and a few parameters
//! costs the same as the adjoint and needs one pass.
//!
//! Every contribution is the integrand `c(x, theta)` divided by a pdf `p(x)` that does
//! not depend on `theta` here; so `E[dc/dtheta / p] = d/dtheta E[c / p]`, the derivative of
//! the expected cube (Leibniz: the integrand is smooth in these parameters and the
//! integration domain does not move with them, which is why geometry is not
//! differentiable this way: see docs/gradients.md).
//!
//! - **Albedo** `a` of a material sets its base colour factor to grey `(a, a, a)`: the
//!   band's base colour is `rho = a x (texture's band value)`, and every BSDF with a base
//!   colour is affine in `rho` at fixed lobe probabilities ([`super::bsdf::derivative`]).
//!   Where `rho = 0` (a zero albedo), directions are drawn from the BSDF at `a = 1`
//!   instead (any pdf positive where `df/da` is not zero keeps the estimator unbiased):
//!   the path goes on with `T = 0` and `dT` not zero.
//! - **Emission** `e` of a material sets its emissive colour to grey `(e, e, e)`; a
//!   **light's intensity** `I` its colour times intensity to grey `I`: the emitted
//!   radiance and the radiant intensity are linear in them, `dLe/de = Le / e`,
//!   `dI/dI = I_toward / I`. Both must be positive (at 0 the material or light is not
//!   a light source at all, and the light tables that sampling uses would change).
//! - **Russian roulette** survives with probability `q = min(1, max(|T|, max_k |dT_k|))`
//!   (floored by [`RenderSettings::rr_min_survival`](super::RenderSettings)), dividing
//!   `T` and every `dT_k` by `q`: unbiased for each, and a path of zero throughput but
//!   non-zero derivative (behind a black wall whose albedo is asked for) is kept.
//! - Next-event estimation to punctual lights and to emitters with MIS (power heuristic;
//!   the BSDF pdf is the sampling BSDF's, the same in both strategies' weights),
//!   emission found by BSDF sampling, alpha coverage, refraction's slower light, the
//!   box and tent time filters, `min_bounces`, both time and pulse origins.
//! - Not used here: first-vertex splits and light-vertex joins (variance reduction of the
//!   forward render: the expectation they estimate is the same), and participating
//!   media (refused by [`Renderer::vjp`]).

use super::bsdf::derivative::DBase;
use super::bsdf::{Bsdf, Frame, LobeKind};
use super::integrator::power_heuristic;
use super::sampler::{Sampler, dim};
use super::surface::derivative::AlbedoAtHit;
use super::{RenderSettings, Renderer};
use crate::film::{TimeAxis, TimeFilter};
use crate::scene::PulseOrigin;
use crate::units::C_M_PER_S;
use glam::Vec3;
use rayon::prelude::*;

/// Most parameters one derivative render carries (each path holds this many floats).
pub const MAX_WRT: usize = 16;

/// One parameter a derivative is taken with respect to, by index into the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Wrt {
    /// The albedo of `Scene::materials[material]` (its base colour factor grey).
    Albedo { material: usize },
    /// The emitted radiance of `Scene::materials[material]`, W / (m^2 sr); `value` is
    /// its current value, > 0.
    Emission { material: usize, value: f32 },
    /// The radiant intensity of `Scene::lights[light]`, W/sr; `value` its current value,
    /// > 0.
    Intensity { light: usize, value: f32 },
}

/// What the derivative render's contributions are weighed by: the caller's weights
/// `[height, width, bins]` (row-major, row 0 the top) on `axis`, binned with `filter`.
#[derive(Clone, Copy, Debug)]
pub struct VjpTarget<'a> {
    pub weights: &'a [f32],
    pub width: usize,
    pub height: usize,
    pub axis: TimeAxis,
    pub filter: TimeFilter,
}

/// Why a derivative render cannot run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum VjpError {
    #[error("the weights hold {got} values; the cube is {height} x {width} x {bins} = {need}")]
    WeightsShape {
        got: usize,
        height: usize,
        width: usize,
        bins: usize,
        need: usize,
    },
    #[error("at most {MAX_WRT} parameters per derivative render ({0} asked)")]
    TooMany(usize),
    #[error(
        "the scene has participating media: their derivatives (and the derivatives of \
         surfaces seen through them) are not implemented yet"
    )]
    Media,
    /// The derivative walk has no re-emission (`transport::luminescence`): its paths
    /// would miss the delayed light.
    #[error(
        "material {0:?} is luminescent: re-emitted light is not differentiated yet (its \
         paths would be left out of the gradient)"
    )]
    Luminescent(String),
    #[error("a parameter refers to {0}, which the scene does not have")]
    NoSuchIndex(String),
    #[error("{0} is {1}: an emission or intensity being differentiated must be positive")]
    NotPositive(String, f32),
}

/// Per scene material and light: which parameter (index `k`) it is, if any.
struct Lookup {
    albedo: Vec<Option<usize>>,
    emission: Vec<Option<(usize, f32)>>,
    intensity: Vec<Option<(usize, f32)>>,
    k: usize,
}

impl Lookup {
    fn new(wrt: &[Wrt], materials: usize, lights: usize) -> Result<Lookup, VjpError> {
        if wrt.len() > MAX_WRT {
            return Err(VjpError::TooMany(wrt.len()));
        }
        let mut l = Lookup {
            albedo: vec![None; materials],
            emission: vec![None; materials],
            intensity: vec![None; lights],
            k: wrt.len(),
        };
        for (k, w) in wrt.iter().enumerate() {
            let missing = |what: &str, i: usize| VjpError::NoSuchIndex(format!("{what} {i}"));
            match *w {
                Wrt::Albedo { material } => {
                    *l.albedo
                        .get_mut(material)
                        .ok_or_else(|| missing("material", material))? = Some(k);
                }
                Wrt::Emission { material, value } => {
                    if !(value > 0.0 && value.is_finite()) {
                        return Err(VjpError::NotPositive(
                            format!("material {material}'s emission"),
                            value,
                        ));
                    }
                    *l.emission
                        .get_mut(material)
                        .ok_or_else(|| missing("material", material))? = Some((k, 1.0 / value));
                }
                Wrt::Intensity { light, value } => {
                    if !(value > 0.0 && value.is_finite()) {
                        return Err(VjpError::NotPositive(
                            format!("light {light}'s intensity"),
                            value,
                        ));
                    }
                    *l.intensity
                        .get_mut(light)
                        .ok_or_else(|| missing("light", light))? = Some((k, 1.0 / value));
                }
            }
        }
        Ok(l)
    }
}

/// Derivatives of one contribution, one per parameter.
type Grad = [f32; MAX_WRT];

/// Where a pixel's derivative contributions go: weighed by the caller's weights of the
/// bins they land in, summed per parameter.
struct PixelVjp<'a> {
    /// This pixel's weights, one per bin.
    weights: &'a [f32],
    axis: TimeAxis,
    tent: bool,
    min_bounces: u32,
    k: usize,
    sum: [f64; MAX_WRT],
}

impl PixelVjp<'_> {
    /// The weight of a contribution arriving at `arrival_s` (the film's binning: box or
    /// tent); 0 outside the window.
    fn weight_at(&self, arrival_s: f64) -> f64 {
        let w = |b: usize| self.weights.get(b).copied().unwrap_or(0.0) as f64;
        if self.tent {
            self.axis
                .tent_split(arrival_s)
                .map_or(0.0, |s| s.iter().map(|&(b, share)| share * w(b)).sum())
        } else {
            self.axis.bin_of(arrival_s).map_or(0.0, w)
        }
    }

    fn add(&mut self, arrival_s: f64, scatterings: u32, d: &Grad) {
        if scatterings < self.min_bounces || !arrival_s.is_finite() {
            return;
        }
        let w = self.weight_at(arrival_s);
        if w == 0.0 {
            return;
        }
        for (s, &dk) in self.sum.iter_mut().zip(&d[..self.k]) {
            if dk.is_finite() {
                *s += w * dk as f64;
            }
        }
    }

    fn start_s(&self) -> f64 {
        self.axis.t0_s
    }

    fn end_s(&self) -> f64 {
        self.axis.end_s()
    }
}

/// A path's state between vertices, with its throughput's derivatives.
#[derive(Clone, Copy)]
struct DPath {
    origin: Vec3,
    dir: Vec3,
    throughput: f32,
    d: Grad,
    opl_m: f64,
    vertex_opl_m: f64,
    scatterings: u32,
    ior_here: f32,
    last_pdf: Option<f32>,
    last_position: Vec3,
    pass_throughs: u32,
    unwarp: bool,
}

/// Largest number of straight pass-throughs (alpha coverage) along one segment chain (as
/// in the path integrator).
const MAX_PASS_THROUGH: u32 = 1024;

/// What one vertex's next-event estimate needs of the path and the vertex.
struct Vertex<'a> {
    bsdf: &'a Bsdf,
    /// `(k, df/drho, drho/da)` where the vertex's material's albedo is a parameter.
    albedo: Option<(usize, &'a DBase, f32)>,
    sampler: &'a Bsdf,
    frame: Frame,
    wo: Vec3,
    p: Vec3,
    p_out: Vec3,
    n_face: Vec3,
}

impl Renderer {
    /// The vector-Jacobian product of this renderer's cube with respect to `wrt`:
    /// `sum_{pixel, bin} weights[pixel, bin] d cube[pixel, bin] / d theta_k` for each
    /// parameter, estimated from samples `first .. first + spp` of each pixel's stream
    /// for `seed` (the module doc says how), as a sum over those samples: divide by the
    /// total spp for the estimate. Rows in parallel on the current rayon pool; the same
    /// numbers for any thread count. The units are the cube's per unit of the parameter.
    pub fn vjp(
        &self,
        wrt: &[Wrt],
        target: &VjpTarget,
        seed: u64,
        first: u64,
        spp: u32,
    ) -> Result<Vec<f64>, VjpError> {
        let (w, h, bins) = (target.width, target.height, target.axis.bins);
        let need = w * h * bins;
        if target.weights.len() != need {
            return Err(VjpError::WeightsShape {
                got: target.weights.len(),
                height: h,
                width: w,
                bins,
                need,
            });
        }
        if self.has_media() {
            return Err(VjpError::Media);
        }
        let scene = self.scene();
        if let Some(m) = scene.materials.iter().find(|m| m.luminescence.is_some()) {
            return Err(VjpError::Luminescent(m.name.clone()));
        }
        let lookup = Lookup::new(wrt, scene.materials.len(), scene.lights.len())?;
        let rows: Vec<[f64; MAX_WRT]> = (0..h)
            .into_par_iter()
            .map(|y| {
                let mut row = [0.0f64; MAX_WRT];
                for x in 0..w {
                    let px = y * w + x;
                    let mut sink = PixelVjp {
                        weights: &target.weights[px * bins..(px + 1) * bins],
                        axis: target.axis,
                        tent: target.filter == TimeFilter::Tent,
                        min_bounces: self.settings().min_bounces,
                        k: lookup.k,
                        sum: [0.0; MAX_WRT],
                    };
                    if sink.weights.iter().all(|&v| v == 0.0) {
                        continue;
                    }
                    let mut rng = Sampler::new(seed, 0, px as u64).starting_at(first);
                    for _ in 0..spp {
                        self.d_sample(&lookup, x, y, w, h, &mut rng, &mut sink);
                    }
                    for (r, s) in row.iter_mut().zip(sink.sum) {
                        *r += s;
                    }
                }
                row
            })
            .collect();
        let mut total = vec![0.0f64; lookup.k];
        for row in &rows {
            for (t, r) in total.iter_mut().zip(row) {
                *t += r;
            }
        }
        Ok(total)
    }

    /// One camera sample through pixel `(x, y)` with derivatives.
    #[allow(
        clippy::too_many_arguments,
        reason = "a pixel's coordinates and its sink"
    )]
    fn d_sample(
        &self,
        lookup: &Lookup,
        x: usize,
        y: usize,
        w: usize,
        h: usize,
        rng: &mut Sampler,
        sink: &mut PixelVjp,
    ) {
        rng.start_sample();
        let (jx, jy) = rng.get2(dim::CAMERA);
        let (origin, dir) = self.camera_ray(x as f32 + jx, y as f32 + jy, w, h);
        let start = self.camera().start_opl_m(self.settings().time_origin, dir);
        let path = DPath {
            origin,
            dir,
            throughput: 1.0,
            d: [0.0; MAX_WRT],
            opl_m: start.unwrap_or(0.0),
            vertex_opl_m: start.unwrap_or(0.0),
            scatterings: 0,
            ior_here: 1.0,
            last_pdf: None,
            last_position: origin,
            pass_throughs: 0,
            unwarp: start.is_none(),
        };
        self.d_walk(lookup, path, rng, sink);
    }

    /// Follow `path` until it ends, adding each contribution's derivatives to `sink`:
    /// the path integrator's walk (without splits and light vertices) with `dT` carried.
    fn d_walk(&self, lookup: &Lookup, mut path: DPath, rng: &Sampler, sink: &mut PixelVjp) {
        let s: &RenderSettings = self.settings();
        let lights = self.lights();
        let surfaces = self.surfaces();
        let k = lookup.k;
        let window_end_opl_m = sink.end_s() * C_M_PER_S;
        loop {
            let slot = |use_| dim::vertex(path.scatterings, use_);
            let (origin, dir) = (path.origin, path.dir);
            let Some(hit) = self.accel().closest_hit(origin, dir, f32::INFINITY) else {
                break;
            };
            if path.unwarp {
                path.unwarp = false;
            } else {
                path.opl_m += hit.t_m as f64 * path.ior_here as f64;
            }
            if path.opl_m > window_end_opl_m {
                break;
            }
            let sp = surfaces.at(&hit, origin, dir);
            let u_cover = || match path.pass_throughs {
                0 => rng.get1(slot(dim::COVERAGE)),
                p => rng.get1_hashed(((path.scatterings as u64) << 16) + p as u64),
            };
            if sp.coverage < 1.0 && u_cover() >= sp.coverage {
                path.pass_throughs += 1;
                if path.pass_throughs > MAX_PASS_THROUGH {
                    break;
                }
                path.origin = sp.position - sp.n_face * self.offset_m(sp.position);
                continue;
            }
            let material = surfaces.material_index(hit.triangle);
            if sp.emission > 0.0 {
                let weight = match path.last_pdf {
                    None => 1.0,
                    Some(pdf_bsdf) if s.nee => {
                        let d2 = (sp.position - path.last_position).length_squared();
                        let cos_l = sp.n_face.dot(-dir).abs();
                        let pdf_light = lights.pdf_area(hit.triangle) * d2 / cos_l.max(1e-12);
                        power_heuristic(pdf_bsdf, pdf_light)
                    }
                    Some(_) => 1.0,
                };
                let opl_m = match s.pulse_origin {
                    PulseOrigin::Light => path.opl_m,
                    PulseOrigin::FirstHit => path.vertex_opl_m,
                };
                let g = sp.emission * weight;
                let mut d = [0.0; MAX_WRT];
                for (di, pd) in d.iter_mut().zip(&path.d[..k]) {
                    *di = pd * g;
                }
                if let Some((ke, inv)) = material.and_then(|m| lookup.emission[m]) {
                    d[ke] += path.throughput * g * inv;
                }
                sink.add(opl_m / C_M_PER_S, path.scatterings, &d);
            }
            if path.scatterings >= s.max_bounces {
                break;
            }
            let albedo: Option<(usize, AlbedoAtHit)> = material
                .and_then(|m| lookup.albedo[m])
                .and_then(|ka| surfaces.albedo_at(&hit, &sp).map(|a| (ka, a)));
            let sampler = albedo.map_or(sp.bsdf, |(_, a)| a.sampler);
            let frame = Frame::new(sp.n_shading);
            let wo = frame.to_local(-dir);
            let p_out = sp.position + sp.n_face * self.offset_m(sp.position);
            if s.nee && sampler.has_smooth_lobe() {
                let v = Vertex {
                    bsdf: &sp.bsdf,
                    albedo: albedo
                        .as_ref()
                        .map(|(ka, a)| (*ka, &a.d_bsdf, a.d_rho_per_albedo)),
                    sampler: &sampler,
                    frame,
                    wo,
                    p: sp.position,
                    p_out,
                    n_face: sp.n_face,
                };
                self.d_next_event(lookup, &v, &path, rng, sink);
            }
            // Scatter: a direction from the sampling BSDF, weighed as the hit's own.
            let u_lobe = if sampler.single_lobe() {
                0.0
            } else {
                rng.get1(slot(dim::LOBE))
            };
            let Some(bs) = sampler.sample(wo, u_lobe, rng.get2(slot(dim::BSDF_DIRECTION))) else {
                break;
            };
            let wi_world = frame.to_world(bs.wi);
            let refracted = bs.kind == LobeKind::Refract;
            let geo = wi_world.dot(sp.n_face);
            if (refracted && geo >= 0.0) || (!refracted && geo <= 0.0) {
                break;
            }
            let (weight, d_weight) = match &albedo {
                Some((_, a)) => {
                    let (w, dw) = sampler.detached_weights(&sp.bsdf, Some(&a.d_bsdf), wo, &bs);
                    (w, dw * a.d_rho_per_albedo)
                }
                None => (bs.weight, 0.0),
            };
            for i in 0..k {
                path.d[i] *= weight;
            }
            if let Some((ka, _)) = albedo {
                path.d[ka] += path.throughput * d_weight;
            }
            path.throughput *= weight;
            let u_roulette = slot(dim::ROULETTE);
            path.scatterings += 1;
            if refracted {
                path.ior_here = if sp.front { sp.ior_group } else { 1.0 };
            }
            path.last_pdf = (!bs.is_delta()).then_some(bs.pdf);
            path.last_position = sp.position;
            path.vertex_opl_m = path.opl_m;
            path.pass_throughs = 0;
            path.origin = sp.position + sp.n_face * self.offset_m(sp.position) * geo.signum();
            path.dir = wi_world.normalize();
            let largest_d = path.d[..k].iter().fold(0.0f32, |m, d| m.max(d.abs()));
            if path.scatterings >= s.rr_start {
                // Roulette on the throughput and its derivatives: unbiased for each.
                let q = path
                    .throughput
                    .abs()
                    .max(largest_d)
                    .min(1.0)
                    .max(s.rr_min_survival.min(1.0));
                if !(q > 0.0) || rng.get1(u_roulette) >= q {
                    break;
                }
                path.throughput /= q;
                for i in 0..k {
                    path.d[i] /= q;
                }
            }
            let finite = path.throughput.is_finite() && path.d[..k].iter().all(|d| d.is_finite());
            if !finite || (path.throughput == 0.0 && largest_d == 0.0) {
                break;
            }
        }
    }

    /// Next-event estimation at vertex `v` with derivatives: every punctual light and one
    /// power-sampled emitter point (MIS against the sampling BSDF's pdf), as the path
    /// integrator's.
    fn d_next_event(
        &self,
        lookup: &Lookup,
        v: &Vertex,
        path: &DPath,
        rng: &Sampler,
        sink: &mut PixelVjp,
    ) {
        let k = lookup.k;
        let lights = self.lights();
        let scatterings = path.scatterings + 1;
        let leg_opl_m = |d: f32| self.light_leg_opl_m(d as f64 * path.ior_here as f64);
        let (start_s, end_s) = (sink.start_s(), sink.end_s());
        let outside = |arrival_s: f64| arrival_s > end_s || arrival_s < start_s;
        // `f` and `df/da` toward local `wi`.
        let f_df = |wi: Vec3| {
            let f = v.bsdf.eval(v.wo, wi).0;
            let df = v.albedo.map_or(0.0, |(_, d, per)| d.eval(v.wo, wi) * per);
            (f, df)
        };
        // The derivatives of `T f g`: `dT f g + T df g`, plus `T f g inv` for the light's
        // own parameter `own`.
        let grads = |f: f32, df: f32, g: f32, own: Option<(usize, f32)>| {
            let mut d = [0.0; MAX_WRT];
            for (di, pd) in d.iter_mut().zip(&path.d[..k]) {
                *di = pd * f * g;
            }
            if let Some((ka, _, _)) = v.albedo {
                d[ka] += path.throughput * df * g;
            }
            if let Some((ko, inv)) = own {
                d[ko] += path.throughput * f * g * inv;
            }
            d
        };
        for (i, light) in lights.punctual.iter().enumerate() {
            let to = light.position - v.p;
            let d2 = to.length_squared();
            if !(d2 > 0.0) {
                continue;
            }
            let d = d2.sqrt();
            let wi_world = to / d;
            if wi_world.dot(v.n_face) <= 0.0 {
                continue;
            }
            let wi = v.frame.to_local(wi_world);
            let (f, df) = f_df(wi);
            let intensity = light.intensity_toward(-wi_world);
            if (f <= 0.0 && df == 0.0) || intensity <= 0.0 {
                continue;
            }
            let arrival_s = (path.opl_m + leg_opl_m(d)) / C_M_PER_S;
            if outside(arrival_s) {
                continue;
            }
            let t_max = (light.position - v.p_out).dot(wi_world);
            let tr = self.transmittance(v.p_out, wi_world, t_max);
            if tr > 0.0 {
                let g = wi.z * intensity / d2 * tr;
                let own = lookup.intensity.get(i).copied().flatten();
                sink.add(arrival_s, scatterings, &grads(f, df, g, own));
            }
        }
        if !lights.has_emitters() {
            return;
        }
        let u = rng.get1(dim::vertex(path.scatterings, dim::EMITTER_SELECT));
        let (u1, u2) = rng.get2(dim::vertex(path.scatterings, dim::EMITTER_POINT));
        let Some(es) = lights.sample_emitter(u, u1, u2) else {
            return;
        };
        let surfaces = self.surfaces();
        let to = es.position - v.p;
        let d2 = to.length_squared();
        if !(d2 > 0.0) {
            return;
        }
        let d = d2.sqrt();
        let wi_world = to / d;
        let le = surfaces.emission(es.triangle, es.u, es.v, -wi_world);
        let cos_l = surfaces.geometric_normal(es.triangle).dot(-wi_world).abs();
        if !(le > 0.0 && cos_l > 0.0 && wi_world.dot(v.n_face) > 0.0) {
            return;
        }
        let wi = v.frame.to_local(wi_world);
        let (f, df) = f_df(wi);
        let pdf_bsdf = v.sampler.eval(v.wo, wi).1;
        let arrival_s = (path.opl_m + leg_opl_m(d)) / C_M_PER_S;
        if (f <= 0.0 && df == 0.0) || outside(arrival_s) {
            return;
        }
        let t_max = (es.position - v.p_out).dot(wi_world) - 2.0 * self.offset_m(es.position);
        let tr = self.transmittance(v.p_out, wi_world, t_max);
        if tr > 0.0 {
            let pdf_light = es.pdf_area * d2 / cos_l;
            let w = power_heuristic(pdf_light, pdf_bsdf);
            let g = wi.z * le * w * tr / pdf_light;
            let own = surfaces
                .material_index(es.triangle)
                .and_then(|m| lookup.emission[m]);
            sink.add(arrival_s, scatterings, &grads(f, df, g, own));
        }
    }
}
