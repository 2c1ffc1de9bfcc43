//! What differentiable rendering needs of a hit beyond [`SurfacePoint`]: the scene
//! material it belongs to and how its BSDF changes with the material's albedo
//! ([`crate::transport::derivative`]).

use super::{SurfacePoint, Surfaces, sample_texture};
use crate::accel::Hit;
use crate::transport::bsdf::derivative::DBase;
use crate::transport::bsdf::{BandModel, Bsdf, BsdfParams};

/// A hit's BSDF seen as a function of its material's albedo `a` (the base colour
/// factor set to grey `(a, a, a)`, so that the band's base colour is `a` times the
/// texture's band value).
#[derive(Clone, Copy, Debug)]
pub struct AlbedoAtHit {
    /// `d rho / d a`: the band's base colour per unit albedo here (the base colour
    /// texture's band value, 1 untextured).
    pub d_rho_per_albedo: f32,
    /// `df / d rho`.
    pub d_bsdf: DBase,
    /// The BSDF to sample directions from: the hit's own, or, where its base colour is 0
    /// (no diffuse lobe to sample, while `df/da` has one), the one at albedo 1.
    pub sampler: Bsdf,
}

impl Surfaces {
    /// Index into `Scene::materials` of `triangle`'s material (`None`: the default
    /// material of a triangle without a valid one).
    pub fn material_index(&self, triangle: u32) -> Option<usize> {
        let a = self.scene.attrs.get(triangle as usize)?;
        ((a.material as usize) < self.scene.materials.len()).then_some(a.material as usize)
    }

    /// How the BSDF at `hit` (its [`SurfacePoint`] `sp`) depends on its material's
    /// albedo; `None` where it does not (the black back of a one-sided material, a
    /// conductor).
    pub fn albedo_at(&self, hit: &Hit, sp: &SurfacePoint) -> Option<AlbedoAtHit> {
        if sp.bsdf.is_black() {
            return None;
        }
        let tri = hit.triangle;
        let bm = self.band_material(self.record(tri));
        let (params, d_rho_per_albedo) = if bm.textured {
            let p = self.textured_params(tri, hit.u, hit.v, bm);
            let m = self.material(tri);
            let per = match self.texture(m.base_color_texture) {
                Some(t) => {
                    let c = sample_texture(t, self.uv(tri, hit.u, hit.v), true);
                    self.channel.pick_texel([c[0], c[1], c[2]])
                }
                None => 1.0,
            };
            (p, per)
        } else {
            (bm.params, 1.0)
        };
        let d_bsdf = Bsdf::d_base(&bm.model, &params, sp.front)?;
        let sampler = if params.base > 0.0 || !(d_rho_per_albedo > 0.0) {
            sp.bsdf
        } else {
            let p = BsdfParams {
                base: d_rho_per_albedo.min(1.0),
                ..params
            };
            // A plastic's lobe choice reads the untextured base colour: made anew.
            let channel = self.channel;
            let model = BandModel::new(
                &self.material(tri).model,
                |c| channel.pick(c),
                p.base,
                p.specular_color,
            );
            Bsdf::build(&model, &p, sp.front)
        };
        Some(AlbedoAtHit {
            d_rho_per_albedo,
            d_bsdf,
            sampler,
        })
    }
}
