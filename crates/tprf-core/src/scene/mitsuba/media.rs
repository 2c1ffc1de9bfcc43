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
//! be the scene's and noted. Other phase functions refuse the scene.
//!
//! A `<medium type="heterogeneous">` has the same parameters, `sigma_t` a `gridvolume`
//! (or `grid`): Mitsuba's extinction at a point is `scale sigma_t(p)`, its albedo
//! `albedo` (a constant: a grid of albedos is refused). It becomes a medium of
//! coefficients `sigma_s = scale albedo`, `sigma_a = scale (1 - albedo)` times a
//! [`DensityGrid`] of the volume's values, read from its `.vol` `filename` (one
//! channel), over the volume's box: the unit cube through its `to_world` (a scale and a
//! translation: tprf's grids are axis-aligned), or with `use_grid_bbox` the file's box
//! through it. Mitsuba interpolates the grid as tprf does (trilinear between cell
//! centres, clamped, nothing outside the box).

use super::xml::{Color, err};
use super::{Builder, xml};
use crate::scene::{DensityGrid, Medium, SceneError};
use glam::{DMat4, DVec3};

impl Builder<'_> {
    /// The medium object `k` (a `<medium>` element, or what a `<ref>` named), inside
    /// a boundary of refractive index `n`.
    pub(super) fn medium(&mut self, k: usize, n: f32) -> Result<Medium, SceneError> {
        let o = self.object(k);
        let heterogeneous = match o.plugin.as_str() {
            "homogeneous" => false,
            "heterogeneous" => true,
            _ => {
                return Err(Builder::unsupported(
                    o,
                    "tprf reads homogeneous and heterogeneous (grid) media",
                ));
            }
        };
        let (sigma_t, density) = match (heterogeneous, o.color("sigma_t", Some([1.0; 3]))?) {
            (true, Some(Color::Texture(v))) if self.is_grid(v) => ([1.0; 3], Some(self.grid(v)?)),
            _ => (self.medium_value(o, "sigma_t", 1.0)?, None),
        };
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
            density,
            dispersion: None,
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
                    _ if self.is_grid(k) => Err(Builder::unsupported(
                        v,
                        "tprf's grids scale a medium's sigma_t (a heterogeneous medium's \
                         sigma_t); its albedo is constant",
                    )),
                    _ => Err(Builder::unsupported(
                        v,
                        "tprf reads constvolume and gridvolume volumes",
                    )),
                }
            }
            None => Ok([default; 3]),
        }
    }

    /// Whether volume object `k` is a grid (`gridvolume`, or `grid` as the docs' example
    /// spells it).
    fn is_grid(&self, k: usize) -> bool {
        matches!(self.object(k).plugin.as_str(), "gridvolume" | "grid")
    }

    /// The density grid of `<volume type="gridvolume">` object `k`: its `filename`'s
    /// values over its box (the unit cube, or with `use_grid_bbox` the file's box, through
    /// `to_world`, which must be a positive scale and a translation).
    fn grid(&mut self, k: usize) -> Result<DensityGrid, SceneError> {
        let v = self.object(k);
        let what = format!("{} ({})", v.describe(), v.loc);
        let p = v.prop("filename").ok_or_else(|| {
            err(
                &v.loc,
                format!(
                    "{}: needs <string name=\"filename\"> (a .vol file)",
                    v.describe()
                ),
            )
        })?;
        let name = v.string("filename")?.unwrap_or_default();
        let dir = std::path::Path::new(&*p.loc.file)
            .parent()
            .unwrap_or(std::path::Path::new(""));
        let main = std::path::Path::new(&self.file)
            .parent()
            .unwrap_or(std::path::Path::new(""))
            .to_path_buf();
        let path = xml::resolve_in(dir, &[main], name);
        if let Some(f) = v.string("filter_type")?
            && f != "trilinear"
        {
            return Err(err(
                &v.loc,
                format!("{what}: filter_type \"{f}\": tprf's grids are trilinear"),
            ));
        }
        if let Some(w) = v.string("wrap_mode")?
            && w != "clamp"
        {
            return Err(err(
                &v.loc,
                format!("{what}: wrap_mode \"{w}\": tprf's grids clamp (nothing outside the box)"),
            ));
        }
        for ignored in ["raw", "accel", "max_value"] {
            if v.prop(ignored).is_some() {
                let loc = v.loc.clone();
                self.note_at(&loc, format!("<volume>'s {ignored} ignored"));
            }
        }
        let use_grid_bbox = v.boolean("use_grid_bbox", false)?;
        let to_world = v.transform("to_world")?;
        let mut grid = DensityGrid::read_vol(&path).map_err(|m| err(&v.loc, m))?;
        let [lo, hi] = match (use_grid_bbox, grid.bbox_m) {
            (true, Some([lo, hi])) => [lo.map(f64::from), hi.map(f64::from)],
            _ => [[0.0; 3], [1.0; 3]],
        };
        let (lo, hi) =
            axis_aligned(&to_world, DVec3::from(lo), DVec3::from(hi)).ok_or_else(|| {
                err(
                    &v.loc,
                    format!(
                        "{what}: to_world must be a positive scale and a translation (tprf's grids \
                     are axis-aligned boxes)"
                    ),
                )
            })?;
        grid.bbox_m = Some([lo.as_vec3().to_array(), hi.as_vec3().to_array()]);
        Ok(grid)
    }
}

/// The box `[lo, hi]` through `m` when `m` is a positive scale and a translation.
fn axis_aligned(m: &DMat4, lo: DVec3, hi: DVec3) -> Option<(DVec3, DVec3)> {
    let c = m.to_cols_array_2d();
    let diagonal = (0..3).all(|i| (0..3).all(|j| i == j || c[i][j] == 0.0))
        && (0..3).all(|i| c[i][i] > 0.0)
        && c[0][3] == 0.0
        && c[1][3] == 0.0
        && c[2][3] == 0.0
        && c[3][3] == 1.0;
    diagonal.then(|| (m.transform_point3(lo), m.transform_point3(hi)))
}
