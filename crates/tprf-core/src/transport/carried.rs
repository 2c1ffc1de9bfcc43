//! What a path carries beside its scalar throughput, as a type parameter of the path
//! walk: nothing for an intensity render ([`Intensity`]: every method does what the walk
//! did before and the rest compiles away, so intensity cubes stay bit for bit what they
//! were), or the polarization of the path ([`Polarization`]: a Mueller matrix).
//!
//! The polarized path keeps its scalar throughput `t` (the product of the BSDFs' scalar
//! sample weights and the roulette's factors: every sampling decision is the intensity
//! walk's) and carries `N = T / t`, `T` its Mueller throughput: the product, from the
//! camera, of the rotation into the camera's frame and each vertex's Mueller sample
//! weight `W_k` ([`crate::transport::bsdf::Bsdf::sample_weight_mueller`], whose `M00`
//! is the scalar weight) in the world's implicit frames. A contribution of intensity
//! `v` (the scalar walk's value) from unpolarized light is then the Stokes vector
//! `v N e0`, and through a BSDF evaluation `f` of Mueller matrix `F` it is
//! `v N (F / f) e0`, in the camera's frame.

use super::bsdf::polarized::to_world_mueller;
use super::bsdf::{Bsdf, BsdfSample, Frame};
use super::polarization::Mueller;
use super::polarization::frames::{rotate_stokes_basis, stokes_basis};
use glam::Vec3;

/// The quantity a path carries beside its scalar throughput.
pub(crate) trait Carried: Copy {
    /// Whether this is a polarized walk.
    const POLARIZED: bool;

    /// At the camera: a ray along unit `dir` of a camera whose up vector is `up`.
    fn at_camera(dir: Vec3, up: Vec3) -> Self;

    /// After the BSDF sample `bs` drawn for local `wo` at a vertex of shading `frame`.
    fn scatter(&mut self, bsdf: &Bsdf, frame: &Frame, wo: Vec3, bs: &BsdfSample);

    /// The contribution of unpolarized light of intensity `value` (the scalar walk's,
    /// path throughput included) reaching the eye along the path.
    fn light(&self, value: f32) -> Contribution;

    /// The contribution of unpolarized light reaching local `wo` from local `wi` through
    /// `bsdf` (scalar `f` > 0 there), of intensity `value` (the scalar walk's, `f`
    /// included).
    fn light_through(
        &self,
        value: f32,
        bsdf: &Bsdf,
        frame: &Frame,
        wo: Vec3,
        wi: Vec3,
        f: f32,
    ) -> Contribution;
}

/// What a path hands to its sink: an intensity (`Sink::add`) or a Stokes vector in the
/// camera's frame (`Sink::add_stokes`).
#[derive(Clone, Copy, Debug)]
pub(crate) enum Contribution {
    Intensity(f64),
    Stokes([f64; 4]),
}

/// Intensity only: what the walk always carried.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Intensity;

impl Carried for Intensity {
    const POLARIZED: bool = false;

    #[inline(always)]
    fn at_camera(_dir: Vec3, _up: Vec3) -> Self {
        Intensity
    }

    #[inline(always)]
    fn scatter(&mut self, _bsdf: &Bsdf, _frame: &Frame, _wo: Vec3, _bs: &BsdfSample) {}

    #[inline(always)]
    fn light(&self, value: f32) -> Contribution {
        Contribution::Intensity(value as f64)
    }

    #[inline(always)]
    fn light_through(
        &self,
        value: f32,
        _bsdf: &Bsdf,
        _frame: &Frame,
        _wo: Vec3,
        _wi: Vec3,
        _f: f32,
    ) -> Contribution {
        Contribution::Intensity(value as f64)
    }
}

/// The polarization of a path: `N`, its Mueller throughput over its scalar throughput,
/// taking Stokes vectors in the world's implicit frames ([`stokes_basis`]) to the
/// camera's frame.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Polarization(pub Mueller);

/// The camera's Stokes reference for a ray along unit `dir`: `dir x up`, normalized
/// (mitransient's `stokes` integrator: `cross(ray.d, up)`), the image's x axis for the
/// central ray; so `S1 > 0` is light polarized along the image's x axis.
pub(crate) fn camera_stokes_x(dir: Vec3, up: Vec3) -> Vec3 {
    dir.cross(up).normalize_or(stokes_basis(-dir))
}

impl Carried for Polarization {
    const POLARIZED: bool = true;

    fn at_camera(dir: Vec3, up: Vec3) -> Self {
        // Light reaching the eye travels along -dir, in its implicit frame; re-expressed
        // in the camera's.
        let forward = -dir;
        Polarization(rotate_stokes_basis(
            forward,
            stokes_basis(forward),
            camera_stokes_x(dir, up),
        ))
    }

    fn scatter(&mut self, bsdf: &Bsdf, frame: &Frame, wo: Vec3, bs: &BsdfSample) {
        if !(bs.weight > 0.0) {
            self.0 = Mueller::ZERO;
            return;
        }
        let w = to_world_mueller(frame, &bsdf.sample_weight_mueller(wo, bs), bs.wi, wo);
        self.0 = self.0 * (w * (1.0 / bs.weight));
    }

    fn light(&self, value: f32) -> Contribution {
        let s = self.0.first_column();
        Contribution::Stokes(s.0.map(|c| (c * value) as f64))
    }

    fn light_through(
        &self,
        value: f32,
        bsdf: &Bsdf,
        frame: &Frame,
        wo: Vec3,
        wi: Vec3,
        f: f32,
    ) -> Contribution {
        let m = to_world_mueller(frame, &bsdf.eval_mueller(wo, wi), wi, wo);
        let s = (self.0 * m).first_column();
        let scale = value / f;
        Contribution::Stokes(s.0.map(|c| (c * scale) as f64))
    }
}
