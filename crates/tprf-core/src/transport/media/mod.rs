//! Transient volume rendering: the path tracer for scenes with participating media (the
//! scene-wide medium, media filling closed meshes), a loop of its own beside the
//! surface integrator's, so scenes without media run the surface loop as it was.
//!
//! The transient volume rendering equation along a ray from `x` in direction `w` (the
//! paper's `R = R0 + S P R` with `P` through a medium) is
//! `L(x, w, t) = integral_0^d T(s) sigma_s integral p(w', w) L(x_s, w', t - n s / c) dw' ds
//!  + T(d) L_surface(x_d, w, t - n d / c)`, `T(s) = e^(-sigma_t s)`: a scattering event
//! in the medium is one more vertex of the Neumann series (a bounce), and the light takes
//! `n s / c` to cross `s` metres. Each segment of a path (a ray from a vertex to the next
//! surface) is handled in three parts ([`walk`]):
//!
//! - **Single scattering of the punctual lights on the segment**, estimated on the whole
//!   segment by one point drawn inside its *gate*: the distances whose scattered light
//!   arrives inside the film's window (`distance::gate`), from a mixture of the
//!   transmittance's and the light's `1 / r^2` densities, joined to the light by a
//!   shadow ray. No free-flight luck decides whether a narrow gate is seen.
//! - **The continuation**: the path passes to the surface with probability `q = T(d)`
//!   (on the camera ray `max(T, min(20 T, 1/2))`, so a target behind fog is found by
//!   more than the few samples the fog lets through) when the surface's light can still
//!   arrive in the window (weight `T / q`), else scatters at a distance drawn from the transmittance's density
//!   truncated to the part of the segment that can still arrive in the window (weight
//!   `(1 - T) albedo / (1 - q)`). Unbiased; nothing is traced that could only arrive late.
//! - **A medium vertex**: next-event estimation to the emitters (MIS against phase
//!   sampling), then a new direction from the Henyey-Greenstein phase function
//!   ([`phase`]) or, in a one-sample MIS mixture, toward the glow that the medium makes
//!   around each punctual light (`glow`; surface vertices in a medium mix it with the
//!   BSDF alike), Russian roulette a few scatterings later than on surfaces.
//!
//! Surfaces are as in the surface loop (emission with MIS, next-event estimation,
//! BSDF sampling), with shadow rays attenuated by the media they cross and timed by
//! their indices. Where the path is: the scene's medium, until it refracts into a
//! transmissive material (its medium, or clear at its ior) or crosses into a medium's
//! index-matched boundary; leaving either through a back face returns it to the scene's
//! medium (media do not nest). The camera and the lights are in the scene's medium.
//! Not here: light vertices and first-bounce splitting (the surface loop's strategies),
//! the steady ambient image (rendered without media).
//!
//! **Heterogeneous media** (a density grid scaling the coefficients, [`DensityGrid`]):
//! `sigma_t s` above becomes the optical depth `sigma_t integral_0^s density`, computed
//! exactly along the ray (`grid`); the continuation draws its distance by inverting it
//! (the same `q`, truncation and weights: the albedo is the medium's everywhere), shadow
//! rays and the camera leg of single scattering take its exact transmittance, and single
//! scattering draws its point from the gate clipped to the grid's box, in proportion to
//! `sigma_t(s) T(s)` or to the light's `1 / r^2`, weighted by `sigma_s(s)`. A homogeneous
//! medium (`BandMedium::grid` `None`) takes the code it always took.

mod distance;
mod glow;
mod grid;
pub mod phase;
mod walk;

use crate::scene::{Channel, DensityGrid, Medium, Scene};
use distance::Exponential;
use glam::Vec3;
use grid::GridLine;

/// One region's medium reduced to the band the cube records.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct BandMedium {
    pub sigma_s: f32,
    pub sigma_t: f32,
    pub g: f32,
    /// Refractive index that times the medium: its group index in the band (the index
    /// itself unless it is dispersive). Light crosses `d` in `n d / c`.
    pub n: f32,
    /// A heterogeneous medium's density grid ([`Media::grids`]): `sigma_s` and `sigma_t`
    /// are then its coefficients at density 1.
    pub grid: Option<u32>,
}

impl BandMedium {
    /// Clear, of index `n`: the inside of a dielectric without a medium, or vacuum.
    pub fn clear(n: f32) -> BandMedium {
        BandMedium {
            sigma_s: 0.0,
            sigma_t: 0.0,
            g: 0.0,
            n,
            grid: None,
        }
    }

    /// `m` in the band of `channel`, its density grid (if any) at index `grid`.
    fn new(m: &Medium, channel: Channel, grid: Option<u32>) -> BandMedium {
        let sigma_s = channel.pick(m.sigma_s_per_m).max(0.0);
        let sigma_a = channel.pick(m.sigma_a_per_m).max(0.0);
        BandMedium {
            sigma_s,
            sigma_t: sigma_s + sigma_a,
            g: m.g.clamp(-0.999, 0.999),
            n: m.group_index(channel.index_wavelength_um()).max(1.0),
            grid,
        }
    }

    /// `e^(-sigma_t d)` (a homogeneous medium's; [`Media::transmittance`] for any).
    #[inline]
    pub fn transmittance(&self, d_m: f32) -> f32 {
        if self.sigma_t > 0.0 {
            (-self.sigma_t * d_m).exp()
        } else {
            1.0
        }
    }
}

/// What a material's surface is to the media ([`Media::boundary`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Boundary {
    /// Not a medium's boundary (an opaque or alpha-covered surface; a refracting one
    /// without a medium has a clear inside at its ior).
    Surface { inside: BandMedium },
    /// An index-matched boundary: light crosses it unchanged, into `inside` through the
    /// front face, back into the scene's medium through the back face.
    IndexMatched { inside: BandMedium },
}

/// The scene's media in one band.
pub(crate) struct Media {
    /// The scene-wide medium (clear at index 1 when the scene has none).
    pub scene: BandMedium,
    /// Per scene material.
    boundaries: Vec<Boundary>,
    /// Whether some material is an index-matched boundary (else a shadow ray that is
    /// not blocked stays in the medium it starts in).
    pub has_index_matched: bool,
    /// Least and greatest index of the media a shadow ray may cross: the scene's and the
    /// index-matched ones'.
    pub n_min: f32,
    pub n_max: f32,
    /// The density grids of heterogeneous media, by [`BandMedium::grid`].
    grids: Vec<DensityGrid>,
}

impl Media {
    /// The media of `scene`, or `None` when it has none (a clear scene medium of index
    /// 1 or none, and no material with a medium): then the surface loop renders it.
    pub fn new(scene: &Scene, channel: Channel) -> Option<Media> {
        let vacuum = scene
            .medium
            .as_ref()
            .is_none_or(|m| m.is_clear() && m.n == 1.0);
        let used = |i: usize| scene.attrs.iter().any(|a| a.material as usize == i);
        let any_mesh_medium = scene
            .materials
            .iter()
            .enumerate()
            .any(|(i, m)| m.medium.is_some() && used(i));
        if vacuum && !any_mesh_medium {
            return None;
        }
        let mut grids = Vec::new();
        let mut band = |m: &Medium| {
            let grid = m.density.as_ref().map(|d| {
                grids.push(d.clone());
                (grids.len() - 1) as u32
            });
            BandMedium::new(m, channel, grid)
        };
        let scene_medium = scene
            .medium
            .as_ref()
            .map_or(BandMedium::clear(1.0), &mut band);
        let boundaries: Vec<Boundary> = scene
            .materials
            .iter()
            .map(|m| {
                let ior = super::surface::band_group_ior(m, channel);
                match &m.medium {
                    Some(md) if m.transmission <= 0.0 => {
                        Boundary::IndexMatched { inside: band(md) }
                    }
                    Some(md) => Boundary::Surface {
                        inside: BandMedium { n: ior, ..band(md) },
                    },
                    None => Boundary::Surface {
                        inside: BandMedium::clear(ior),
                    },
                }
            })
            .collect();
        let (mut n_min, mut n_max) = (scene_medium.n, scene_medium.n);
        let mut has_index_matched = false;
        for b in &boundaries {
            if let Boundary::IndexMatched { inside } = b {
                has_index_matched = true;
                n_min = n_min.min(inside.n);
                n_max = n_max.max(inside.n);
            }
        }
        Some(Media {
            scene: scene_medium,
            boundaries,
            has_index_matched,
            n_min,
            n_max,
            grids,
        })
    }

    /// These media with nothing in them: every region clear (no scattering, no
    /// absorption, no density grid) at its own refractive index, so light crosses them
    /// in the same time as through the media themselves. The automatic window's pilot
    /// renders the surfaces' returns with it ([`super::window`]).
    pub fn without_extinction(&self) -> Media {
        let clear = |m: BandMedium| BandMedium::clear(m.n);
        Media {
            scene: clear(self.scene),
            boundaries: self
                .boundaries
                .iter()
                .map(|b| match *b {
                    Boundary::Surface { inside } => Boundary::Surface {
                        inside: clear(inside),
                    },
                    Boundary::IndexMatched { inside } => Boundary::IndexMatched {
                        inside: clear(inside),
                    },
                })
                .collect(),
            has_index_matched: self.has_index_matched,
            n_min: self.n_min,
            n_max: self.n_max,
            grids: Vec::new(),
        }
    }

    /// The ray from `origin` along unit `dir` in `region`'s density grid; `None` for a
    /// homogeneous medium, or a ray that misses the grid's box.
    pub(crate) fn grid_line(
        &self,
        region: &BandMedium,
        origin: Vec3,
        dir: Vec3,
    ) -> Option<GridLine<'_>> {
        let grid = self.grids.get(region.grid? as usize)?;
        GridLine::new(grid, origin.as_dvec3(), dir.as_dvec3())
    }

    /// The transmittance of `region` over the first `d_m` metres of the ray from `origin`
    /// along unit `dir`: `e^(-sigma_t d)`, or with a density grid `e^(-sigma_t
    /// integral_0^d density)` (exact, [`grid`]).
    #[inline(always)]
    pub fn transmittance(&self, region: &BandMedium, origin: Vec3, dir: Vec3, d_m: f32) -> f32 {
        match region.grid {
            None => region.transmittance(d_m),
            Some(_) => self.grid_transmittance(region, origin, dir, d_m),
        }
    }

    /// [`Media::transmittance`] in a density grid (kept out of the homogeneous path).
    #[inline(never)]
    fn grid_transmittance(&self, region: &BandMedium, origin: Vec3, dir: Vec3, d_m: f32) -> f32 {
        if !(region.sigma_t > 0.0) {
            return 1.0;
        }
        match self.grid_line(region, origin, dir) {
            None => 1.0,
            Some(line) => {
                let tau = region.sigma_t as f64 * line.integral(0.0, d_m as f64);
                (-tau).exp() as f32
            }
        }
    }

    /// A free-flight distance on `[0, span_m)` of the ray from `origin` along unit `dir`
    /// for `u` in [0, 1), drawn in proportion to `sigma_t(s) T(s)` (the density of the
    /// first collision, truncated to the span), and the probability of a collision within
    /// the span, `1 - T(span)`. Homogeneous: `sigma_t e^(-sigma_t s)` ([`Exponential`]);
    /// with a grid the optical depth `-ln(1 - u (1 - T(span)))` inverted along the ray.
    #[inline(always)]
    pub fn free_flight(
        &self,
        region: &BandMedium,
        origin: Vec3,
        dir: Vec3,
        span_m: f64,
        u: f64,
    ) -> (f64, f64) {
        match region.grid {
            None => {
                let sigma_t = region.sigma_t as f64;
                let d = Exponential::new(0.0, span_m, sigma_t).sample(u);
                (d, -(-sigma_t * span_m).exp_m1())
            }
            Some(_) => self.grid_free_flight(region, origin, dir, span_m, u),
        }
    }

    /// [`Media::free_flight`] in a density grid (kept out of the homogeneous path).
    #[inline(never)]
    fn grid_free_flight(
        &self,
        region: &BandMedium,
        origin: Vec3,
        dir: Vec3,
        span_m: f64,
        u: f64,
    ) -> (f64, f64) {
        let sigma_t = region.sigma_t as f64;
        let line = self.grid_line(region, origin, dir);
        let Some(line) = line.filter(|_| sigma_t > 0.0) else {
            return (0.0, 0.0);
        };
        let mass = -(-sigma_t * line.integral(0.0, span_m)).exp_m1();
        let target = -(-u * mass).ln_1p() / sigma_t;
        let d = line.invert(0.0, span_m, target).unwrap_or(span_m);
        (d.clamp(0.0, span_m), mass)
    }

    /// Whether a shadow ray from `region` stays in media of its index, so that the time
    /// a point's light arrives is known before tracing it (the gate of single scattering).
    #[inline]
    pub fn index_fixed(&self, region: &BandMedium) -> bool {
        !self.has_index_matched || (self.n_min == region.n && self.n_max == region.n)
    }

    /// What the surface of scene material `material` is (a material out of range: a
    /// plain surface with a clear inside at the default ior).
    #[inline]
    pub fn boundary(&self, material: u32) -> Boundary {
        self.boundaries
            .get(material as usize)
            .copied()
            .unwrap_or(Boundary::Surface {
                inside: BandMedium::clear(1.5),
            })
    }
}
