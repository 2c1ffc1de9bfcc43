//! Mitsuba's `<medium type="homogeneous">` onto tprf's [`Medium`].
//!
//! Mitsuba gives a homogeneous medium its extinction `sigma_t` and single-scattering
//! `albedo` (each a number or RGB, per scene unit: per metre here) times `scale`, and a
//! `<phase>` (`isotropic`, or `hg` with `g`); tprf's medium is the scattering and
//! absorption coefficients, `sigma_s = scale albedo sigma_t` and
//! `sigma_a = scale (1 - albedo) sigma_t`, the Henyey-Greenstein `g` (0 for isotropic)
//! and the refractive index `n`, which Mitsuba keeps on the boundary's BSDF: the
//! `int_ior` of a `dielectric` around the medium, 1 behind a `null` BSDF (an
//! index-matched boundary) and for the medium the sensor sits in (the scene's).
//!
//! Where a medium is used: inside a `<sensor>` it is the scene's medium (the air the
//! camera and the lights sit in); a shape's `interior` medium fills that closed mesh
//! (its material's medium); a shape's `exterior` and an emitter's medium are taken to
//! be the scene's and noted. Heterogeneous media (`heterogeneous`, grid `volume`s) and
//! other phase functions refuse the scene.

use super::xml::{Color, err};
use super::{Builder, xml};
use crate::scene::{Medium, SceneError};

impl Builder<'_> {
    /// The medium object `k` (a `<medium>` element, or what a `<ref>` named), inside
    /// a boundary of refractive index `n`.
    pub(super) fn medium(&mut self, k: usize, n: f32) -> Result<Medium, SceneError> {
        let o = self.object(k);
        if o.plugin != "homogeneous" {
            return Err(Builder::unsupported(
                o,
                "tprf renders homogeneous media only (sigma_t and albedo constant)",
            ));
        }
        let sigma_t = self.medium_value(o, "sigma_t", 1.0)?;
        let albedo = self.medium_value(o, "albedo", 0.75)?;
        let scale = o.float("scale", 1.0)?;
        if albedo.iter().any(|a| !(0.0..=1.0).contains(a)) {
            return Err(err(
                &o.loc,
                format!("{}: albedo {albedo:?} must be in [0, 1]", o.describe()),
            ));
        }
        for ignored in ["sample_emitters", "has_spectral_extinction"] {
            if o.prop(ignored).is_some() {
                let loc = o.loc.clone();
                self.note_at(
                    &loc,
                    format!("<medium>'s {ignored} ignored (tprf samples emitters from media)"),
                );
            }
        }
        let mut g = 0.0;
        for (p, c) in o.children() {
            p.used.set(true);
            // A volume given for sigma_t or albedo was read above.
            if p.name == "albedo" || p.name == "sigma_t" {
                continue;
            }
            let child = self.object(c);
            match (child.tag, child.plugin.as_str()) {
                ("phase", "isotropic") => g = 0.0,
                ("phase", "hg") => g = child.float("g", 0.8)?,
                ("phase", _) => {
                    return Err(Builder::unsupported(
                        child,
                        "tprf's media scatter by Henyey-Greenstein (isotropic or hg)",
                    ));
                }
                _ => {
                    return Err(err(
                        &child.loc,
                        format!(
                            "{} inside {} is not supported",
                            child.describe(),
                            o.describe()
                        ),
                    ));
                }
            }
        }
        let per = |f: fn(f64, f64) -> f64| -> [f32; 3] {
            std::array::from_fn(|i| (scale * f(sigma_t[i], albedo[i])) as f32)
        };
        let medium = Medium {
            sigma_s_per_m: per(|t, a| a * t),
            sigma_a_per_m: per(|t, a| (1.0 - a) * t),
            g: g as f32,
            n,
        };
        medium.validate(&format!("{} ({})", o.describe(), o.loc))?;
        Ok(medium)
    }

    /// `sigma_t` or `albedo` of a homogeneous medium: a number, `<rgb>`, a uniform
    /// `<spectrum>`, or a constant volume/texture; a grid refuses the scene.
    fn medium_value(
        &self,
        o: &xml::Object,
        name: &str,
        default: f64,
    ) -> Result<[f64; 3], SceneError> {
        match o.color(name, Some([default; 3]))? {
            Some(Color::Rgb(c)) => Ok(c),
            Some(Color::Texture(k)) => {
                let v = self.object(k);
                match v.plugin.as_str() {
                    "constvolume" => match v.color("value", Some([1.0; 3]))? {
                        Some(Color::Rgb(c)) => Ok(c),
                        _ => Err(err(&v.loc, format!("{}: a constant value", v.describe()))),
                    },
                    _ => Err(Builder::unsupported(
                        v,
                        "tprf renders homogeneous media only (a grid volume is heterogeneous)",
                    )),
                }
            }
            None => Ok([default; 3]),
        }
    }
}
