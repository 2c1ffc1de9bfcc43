//! Exact answers the renderer is measured against, derived independently of it: the
//! transient furnace ([`furnace`]), a plane lit by a point light on the camera's axis
//! ([`plane`]; made luminescent: [`luminescent_plane`]) and the paper's 1-D world built as a 3-D scene of mirrors ([`oned_scene`]).
//!
//! Each reference builds its own scene and, for any film shape, the expected cube: per
//! pixel, per time bin, the integral over the bin of the pixel's radiance (DESIGN.md).
//! The convergence report ([`crate::report`]) renders the scene and compares; the tests
//! compare the renderer with the same formulas.
//!
//! A reference is named by a spec string: `analytic:furnace?rho=0.9`,
//! `analytic:furnace?rho=0.5&light=area`, `analytic:plane`, `analytic:oned`,
//! `analytic:oned?world=assets/oned/figure4.json` (see [`Analytic::parse`]).

pub mod furnace;
pub mod luminescent_plane;
pub mod oned_scene;
pub mod plane;
mod quadrature;

pub use quadrature::{BinSpreader, gauss_legendre};

use crate::film::{FilmError, TimeAxis};
use crate::scene::Scene;
use furnace::{Furnace, FurnaceLight};
use oned_scene::OnedScene;
use plane::Plane;

/// Why a reference spec cannot be used. Messages name the parameter and the problem.
#[derive(Debug, thiserror::Error)]
pub enum ReferenceError {
    #[error("unknown reference '{0}' (known: analytic:furnace, analytic:plane, analytic:oned)")]
    Unknown(String),
    #[error("reference '{spec}': unknown parameter '{key}' (known: {known})")]
    UnknownParameter {
        spec: String,
        key: String,
        known: &'static str,
    },
    #[error("reference '{spec}': parameter '{key}' = '{value}': {why}")]
    BadParameter {
        spec: String,
        key: String,
        value: String,
        why: String,
    },
    #[error("reference '{spec}': {why}")]
    Unsupported { spec: String, why: String },
    #[error("no light of this 1-D world reaches the eye")]
    Dark,
    /// The time axis asked for is not a valid [`TimeAxis`].
    #[error(transparent)]
    Axis(#[from] FilmError),
}

/// An exact reference: its scene, a film shape that suits it, and the expected cube.
#[derive(Clone, Debug, PartialEq)]
pub enum Analytic {
    Furnace(Furnace),
    Plane(Plane),
    Oned(Box<OnedScene>),
}

/// The expected cube `[H, W, T]` (row 0 = top), f64, bin integrals of radiance.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceCube {
    pub width: usize,
    pub height: usize,
    pub axis: TimeAxis,
    pub values: Vec<f64>,
}

impl ReferenceCube {
    /// Steady image `[H, W]`: per pixel the sum over bins.
    pub fn steady(&self) -> Vec<f64> {
        self.values
            .chunks(self.axis.bins.max(1))
            .map(|c| c.iter().sum())
            .collect()
    }
}

/// `key=value` pairs of a spec.
type Pairs<'a> = Vec<(&'a str, &'a str)>;

/// Split `spec` into its name and `key=value` pairs (`analytic:NAME?k=v&k=v`).
fn split_spec(spec: &str) -> Result<(&str, Pairs<'_>), ReferenceError> {
    let body = spec
        .strip_prefix("analytic:")
        .ok_or_else(|| ReferenceError::Unknown(spec.to_string()))?;
    let (name, query) = match body.split_once('?') {
        Some((n, q)) => (n, q),
        None => (body, ""),
    };
    let mut pairs = Vec::new();
    for part in query.split('&').filter(|p| !p.is_empty()) {
        let (k, v) = part
            .split_once('=')
            .ok_or_else(|| ReferenceError::BadParameter {
                spec: spec.to_string(),
                key: part.to_string(),
                value: String::new(),
                why: "expected key=value".into(),
            })?;
        pairs.push((k.trim(), v.trim()));
    }
    Ok((name, pairs))
}

/// Parse a finite number, with `check` for its range.
fn number(
    spec: &str,
    key: &str,
    value: &str,
    check: impl Fn(f64) -> Result<(), String>,
) -> Result<f64, ReferenceError> {
    let bad = |why: String| ReferenceError::BadParameter {
        spec: spec.to_string(),
        key: key.to_string(),
        value: value.to_string(),
        why,
    };
    let x: f64 = value.parse().map_err(|_| bad("not a number".to_string()))?;
    if !x.is_finite() {
        return Err(bad("not a finite number".into()));
    }
    check(x).map_err(bad)?;
    Ok(x)
}

fn positive(x: f64) -> Result<(), String> {
    if x > 0.0 {
        Ok(())
    } else {
        Err("must be > 0".into())
    }
}

impl Analytic {
    /// Parse a spec:
    ///
    /// - `analytic:furnace` with `rho` (albedo in [0, 1), default 0.9), `r` (radius, m,
    ///   default 1), `light=point|area` (default point), `i` (point light, W/sr, default 1)
    ///   or `le` (emitted radiance of the wall for `light=area`, default 1);
    /// - `analytic:plane` with `h` (camera height, m, default 2), `rho` (default 0.5),
    ///   `i` (W/sr, default 3), `fov` (degrees, default 40), `light_h` (light height on
    ///   the camera's axis, m, default: at the camera), `sigma_a` (a purely absorbing
    ///   medium filling space, 1/m, default 0) and `n` (its refractive index, default 1);
    /// - `analytic:oned` with `world` (a 1-D world file, default the paper's Figure 4
    ///   world, `assets/oned/figure4.json`).
    pub fn parse(spec: &str) -> Result<Analytic, ReferenceError> {
        let (name, pairs) = split_spec(spec)?;
        match name {
            "furnace" => {
                let mut f = Furnace::default();
                let mut light_area = false;
                let (mut i, mut le) = (None, None);
                for (k, v) in pairs {
                    match k {
                        "rho" => {
                            f.rho = number(spec, k, v, |x| {
                                if (0.0..1.0).contains(&x) {
                                    Ok(())
                                } else {
                                    Err("the albedo must be in [0, 1)".into())
                                }
                            })?
                        }
                        "r" => f.radius_m = number(spec, k, v, positive)?,
                        "i" => i = Some(number(spec, k, v, positive)?),
                        "le" => le = Some(number(spec, k, v, positive)?),
                        "light" => {
                            light_area = match v {
                                "point" => false,
                                "area" => true,
                                _ => {
                                    return Err(ReferenceError::BadParameter {
                                        spec: spec.into(),
                                        key: k.into(),
                                        value: v.into(),
                                        why: "expected point or area".into(),
                                    });
                                }
                            }
                        }
                        _ => {
                            return Err(ReferenceError::UnknownParameter {
                                spec: spec.into(),
                                key: k.into(),
                                known: "rho, r, light, i, le",
                            });
                        }
                    }
                }
                f.light = if light_area {
                    if i.is_some() {
                        return Err(ReferenceError::Unsupported {
                            spec: spec.into(),
                            why: "'i' is the point light's intensity; with light=area give 'le'"
                                .into(),
                        });
                    }
                    FurnaceLight::Area {
                        radiance: le.unwrap_or(1.0),
                    }
                } else {
                    if le.is_some() {
                        return Err(ReferenceError::Unsupported {
                            spec: spec.into(),
                            why: "'le' is the wall's emission; it needs light=area".into(),
                        });
                    }
                    FurnaceLight::Point {
                        intensity_w_per_sr: i.unwrap_or(1.0),
                    }
                };
                Ok(Analytic::Furnace(f))
            }
            "plane" => {
                let mut p = Plane::default();
                let mut light_h = None;
                for (k, v) in pairs {
                    match k {
                        "h" => p.camera_height_m = number(spec, k, v, positive)?,
                        "light_h" => light_h = Some(number(spec, k, v, positive)?),
                        "rho" => {
                            p.rho = number(spec, k, v, |x| {
                                if (0.0..=1.0).contains(&x) {
                                    Ok(())
                                } else {
                                    Err("the albedo must be in [0, 1]".into())
                                }
                            })?
                        }
                        "i" => p.intensity_w_per_sr = number(spec, k, v, positive)?,
                        "sigma_a" => {
                            p.sigma_a_per_m = number(spec, k, v, |x| {
                                if x >= 0.0 {
                                    Ok(())
                                } else {
                                    Err("the absorption must be >= 0 (per metre)".into())
                                }
                            })?
                        }
                        "n" => {
                            p.n = number(spec, k, v, |x| {
                                if x >= 1.0 {
                                    Ok(())
                                } else {
                                    Err("the refractive index must be >= 1".into())
                                }
                            })?
                        }
                        "fov" => {
                            p.fov_deg = number(spec, k, v, |x| {
                                if x > 0.0 && x < 170.0 {
                                    Ok(())
                                } else {
                                    Err("the field of view must be in (0, 170) degrees".into())
                                }
                            })?
                        }
                        _ => {
                            return Err(ReferenceError::UnknownParameter {
                                spec: spec.into(),
                                key: k.into(),
                                known: "h, light_h, rho, i, fov, sigma_a, n",
                            });
                        }
                    }
                }
                p.light_height_m = light_h.unwrap_or(p.camera_height_m);
                p.check().map_err(|why| ReferenceError::Unsupported {
                    spec: spec.into(),
                    why,
                })?;
                Ok(Analytic::Plane(p))
            }
            "oned" => {
                let mut world = None;
                for (k, v) in pairs {
                    match k {
                        "world" => {
                            world = Some(
                                crate::oned::World::from_path(std::path::Path::new(v)).map_err(
                                    |e| ReferenceError::BadParameter {
                                        spec: spec.into(),
                                        key: k.into(),
                                        value: v.into(),
                                        why: e.to_string(),
                                    },
                                )?,
                            )
                        }
                        _ => {
                            return Err(ReferenceError::UnknownParameter {
                                spec: spec.into(),
                                key: k.into(),
                                known: "world",
                            });
                        }
                    }
                }
                let world = match world {
                    Some(w) => w,
                    None => oned_scene::figure4_world(),
                };
                let s = OnedScene::new(world).map_err(|why| ReferenceError::Unsupported {
                    spec: spec.into(),
                    why,
                })?;
                Ok(Analytic::Oned(Box::new(s)))
            }
            _ => Err(ReferenceError::Unknown(spec.to_string())),
        }
    }

    /// A short name for plots and files: `furnace rho=0.9`, `plane`, `oned`.
    pub fn label(&self) -> String {
        match self {
            Analytic::Furnace(f) => match f.light {
                FurnaceLight::Point { .. } => format!("furnace rho={}", f.rho),
                FurnaceLight::Area { .. } => format!("furnace rho={} (emitting wall)", f.rho),
            },
            Analytic::Plane(_) => "plane".into(),
            Analytic::Oned(_) => "1-D world".into(),
        }
    }

    /// The scene the reference describes.
    pub fn scene(&self) -> Scene {
        match self {
            Analytic::Furnace(f) => f.scene(),
            Analytic::Plane(p) => p.scene(),
            Analytic::Oned(o) => o.scene(),
        }
    }

    /// A film that suits the reference: `(width, height, bins)`.
    pub fn default_film(&self) -> (usize, usize, usize) {
        match self {
            Analytic::Furnace(_) => (32, 32, 128),
            Analytic::Plane(_) => (32, 32, 64),
            Analytic::Oned(_) => (4, 4, 256),
        }
    }

    /// A time axis of `bins` bins that holds what matters of the answer for a
    /// `width x height` film.
    pub fn default_axis(
        &self,
        width: usize,
        height: usize,
        bins: usize,
    ) -> Result<TimeAxis, ReferenceError> {
        match self {
            Analytic::Furnace(f) => Ok(f.default_axis(bins)?),
            Analytic::Plane(p) => Ok(p.default_axis(width, height, bins)?),
            Analytic::Oned(o) => o.default_axis(bins),
        }
    }

    /// The expected cube on `axis` for a `width x height` film.
    pub fn cube(&self, width: usize, height: usize, axis: &TimeAxis) -> ReferenceCube {
        let t = axis.bins;
        let mut values = vec![0.0; width * height * t];
        match self {
            Analytic::Furnace(f) => {
                let tprf = f.tprf(axis);
                for px in values.chunks_mut(t) {
                    px.copy_from_slice(&tprf);
                }
            }
            Analytic::Oned(o) => {
                let tprf = o.tprf(axis);
                for px in values.chunks_mut(t) {
                    px.copy_from_slice(&tprf);
                }
            }
            Analytic::Plane(p) => {
                use rayon::prelude::*;
                values
                    .par_chunks_mut(t.max(1))
                    .enumerate()
                    .for_each(|(i, px)| {
                        let (x, y) = (i % width, i / width);
                        px.copy_from_slice(&p.pixel_tprf(x, y, width, height, axis));
                    });
            }
        }
        ReferenceCube {
            width,
            height,
            axis: *axis,
            values,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_parse_and_bad_ones_are_errors() {
        assert!(matches!(
            Analytic::parse("analytic:furnace?rho=0.99").unwrap(),
            Analytic::Furnace(Furnace { rho, .. }) if rho == 0.99
        ));
        assert!(matches!(
            Analytic::parse("analytic:plane").unwrap(),
            Analytic::Plane(_)
        ));
        assert!(matches!(
            Analytic::parse("analytic:oned").unwrap(),
            Analytic::Oned(_)
        ));
        for bad in [
            "analytic:furnace?rho=NaN",
            "analytic:furnace?rho=1",
            "analytic:furnace?rho=-0.1",
            "analytic:furnace?rho",
            "analytic:furnace?colour=red",
            "analytic:furnace?light=area&i=2",
            "analytic:plane?fov=inf",
            "analytic:teapot",
            "furnace",
            "analytic:oned?world=/nonexistent.json",
        ] {
            let e = Analytic::parse(bad);
            assert!(e.is_err(), "{bad} accepted");
        }
    }
}
