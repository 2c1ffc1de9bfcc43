//! Participating media: homogeneous volumes that scatter and absorb light, and in which
//! light travels at `c / n` (the paper's per-region speed of light, section 7's
//! "transient volume rendering").
//!
//! A medium is given by its scattering and absorption coefficients (per metre, per
//! colour channel: the band the cube records picks one, as for colours), its
//! Henyey-Greenstein asymmetry `g` and its refractive index `n`. Light crossing a length
//! `d` of it keeps the fraction `exp(-sigma_t d)` (`sigma_t = sigma_s + sigma_a`, the
//! extinction) and takes `n d / c`; a scattering event turns it by the Henyey-Greenstein
//! phase function of `g` and counts as a bounce.
//!
//! Where media come from:
//! - the scene-wide medium (the air: fog, haze, water), [`super::Scene::medium`]: the
//!   glTF scene's extras `{"tprf": {"medium": {...}}}` or `tprf render --medium SPEC`
//!   ([`Medium::parse_spec`]);
//! - a medium filling a closed mesh, [`super::Material::medium`]: the absorption of glTF
//!   `KHR_materials_volume` (`attenuationColor`, `attenuationDistance`) on a transmissive
//!   material, and the material's extras `{"tprf": {"medium": {...}}}` ([`Medium::from_json`]).

use super::SceneError;
use super::density::DensityGrid;
use super::dispersion::Dispersion;
use std::path::Path;

/// Extinction times the meteorological optical range: `-ln(0.02)`, the contrast
/// threshold of 2 % (Koschmieder; WMO's definition of visibility). A medium of visibility
/// `V` has extinction `3.912 / V`.
pub const MOR_EXTINCTION: f64 = 3.912;

/// Asymmetry of the `visibility=` shortcut's fog when no `g` is given: water droplets of
/// fog scatter strongly forward (g about 0.85-0.9 from the visible to the near infrared).
pub const FOG_G: f32 = 0.9;

/// A participating medium: homogeneous, or heterogeneous with a density grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Medium {
    /// Scattering coefficient per channel (linear RGB bands), 1/m.
    pub sigma_s_per_m: [f32; 3],
    /// Absorption coefficient per channel, 1/m.
    pub sigma_a_per_m: [f32; 3],
    /// Henyey-Greenstein asymmetry, in (-1, 1): 0 isotropic, > 0 forward.
    pub g: f32,
    /// Refractive index, at least 1: light travels at `c / n` in the medium. With a
    /// `dispersion`, its value at the d line.
    pub n: f32,
    /// The index as a function of wavelength (`n=bk7`, `n=cauchy:A:B` ...): a band at a
    /// wavelength times the medium by its group index there. `None`: `n` in every band.
    pub dispersion: Option<Dispersion>,
    /// A heterogeneous medium's density: the coefficients above are scaled by the
    /// grid's value at each point ([`DensityGrid`]); `None` for a homogeneous medium.
    pub density: Option<DensityGrid>,
}

impl Medium {
    /// A grey medium: the same coefficients in every channel.
    pub fn grey(sigma_s_per_m: f32, sigma_a_per_m: f32, g: f32, n: f32) -> Medium {
        Medium {
            sigma_s_per_m: [sigma_s_per_m; 3],
            sigma_a_per_m: [sigma_a_per_m; 3],
            g,
            n,
            dispersion: None,
            density: None,
        }
    }

    /// The index `n` in a band at `lambda_um` micrometres for timing: the dispersion's
    /// group index there, else `n`.
    pub fn group_index(&self, lambda_um: f64) -> f32 {
        self.dispersion
            .as_ref()
            .map_or(self.n, |d| d.group_index(lambda_um) as f32)
    }

    /// Fog of meteorological optical range `visibility_m` (extinction `3.912 / V`), of
    /// single-scattering albedo `albedo`.
    pub fn from_visibility(visibility_m: f64, albedo: f64, g: f32, n: f32) -> Medium {
        let sigma_t = MOR_EXTINCTION / visibility_m;
        Medium::grey(
            (sigma_t * albedo) as f32,
            (sigma_t * (1.0 - albedo)) as f32,
            g,
            n,
        )
    }

    /// Extinction `sigma_s + sigma_a` per channel, 1/m.
    pub fn sigma_t_per_m(&self) -> [f32; 3] {
        [0, 1, 2].map(|c| self.sigma_s_per_m[c] + self.sigma_a_per_m[c])
    }

    /// Meteorological optical range `3.912 / sigma_t` of the largest channel's extinction,
    /// metres (infinite for a clear medium).
    pub fn visibility_m(&self) -> f64 {
        let t = self.sigma_t_per_m().into_iter().fold(0.0f32, f32::max) as f64;
        MOR_EXTINCTION / t
    }

    /// Whether light crossing it is neither scattered nor absorbed (it may still be slowed).
    pub fn is_clear(&self) -> bool {
        self.sigma_t_per_m().iter().all(|&s| s == 0.0)
            || self.density.as_ref().is_some_and(|d| d.max() == 0.0)
    }

    /// The same medium in a scene scaled by `s` (lengths times `s`): coefficients over `s`
    /// and a grid's box times `s`, so every optical depth, and the picture, stay as they
    /// were.
    pub fn scaled(self, s: f32) -> Medium {
        Medium {
            sigma_s_per_m: self.sigma_s_per_m.map(|v| v / s),
            sigma_a_per_m: self.sigma_a_per_m.map(|v| v / s),
            density: self.density.map(|d| d.scaled(s)),
            ..self
        }
    }

    /// Check the medium: coefficients finite and >= 0, `g` in (-1, 1), `n` finite and
    /// >= 1. The message names `what` (the medium's owner) and the field.
    pub fn validate(&self, what: &str) -> Result<(), SceneError> {
        let bad_coefficient = |v: &[f32; 3]| v.iter().any(|x| !(x.is_finite() && *x >= 0.0));
        if bad_coefficient(&self.sigma_s_per_m) {
            return Err(SceneError::Invalid(format!(
                "{what}: sigma_s_per_m {:?} must be finite and >= 0 (per metre)",
                self.sigma_s_per_m
            )));
        }
        if bad_coefficient(&self.sigma_a_per_m) {
            return Err(SceneError::Invalid(format!(
                "{what}: sigma_a_per_m {:?} must be finite and >= 0 (per metre)",
                self.sigma_a_per_m
            )));
        }
        if !(self.g > -1.0 && self.g < 1.0) {
            return Err(SceneError::Invalid(format!(
                "{what}: g = {} must be in (-1, 1) (the Henyey-Greenstein asymmetry)",
                self.g
            )));
        }
        if !(self.n.is_finite() && self.n >= 1.0) {
            return Err(SceneError::Invalid(format!(
                "{what}: n = {} must be finite and >= 1 (the refractive index)",
                self.n
            )));
        }
        if let Some(d) = &self.density {
            d.validate(what).map_err(SceneError::Invalid)?;
        }
        Ok(())
    }

    /// The medium in words: `sigma_s 0.05/m, sigma_a 0.001/m, g 0.9, n 1 (visibility
    /// 76.7 m)`; a channel triple where the channels differ.
    pub fn describe(&self) -> String {
        let v = |c: [f32; 3]| {
            if c[0] == c[1] && c[1] == c[2] {
                format!("{}/m", c[0])
            } else {
                format!("{c:?}/m")
            }
        };
        let mut s = format!(
            "sigma_s {}, sigma_a {}, g {}, n {}",
            v(self.sigma_s_per_m),
            v(self.sigma_a_per_m),
            self.g,
            match &self.dispersion {
                Some(d) => format!("{} ({} at the d line)", d.describe(), self.n),
                None => self.n.to_string(),
            }
        );
        match &self.density {
            Some(d) => s.push_str(&format!(", times a {}", d.describe())),
            None => {
                let vis = self.visibility_m();
                if vis.is_finite() {
                    s.push_str(&format!(" (visibility {vis:.4} m)"));
                }
            }
        }
        s
    }

    /// Parse the command line's medium: comma-separated `key=value` pairs.
    ///
    /// - `sigma_s=0.05/m`, `sigma_a=0.001/m`: coefficients per metre (`/m`, or `/cm`,
    ///   `/mm`, `/km`; a bare number is per metre), both 0 when not given;
    /// - `g=0.9`: Henyey-Greenstein asymmetry (default 0);
    /// - `n=1.33`: refractive index (default 1); or dispersive ([`Dispersion::parse`]):
    ///   `n=cauchy:A:B` (B in um^2), `n=sellmeier:B1:B2:B3:C1:C2:C3` (C in um^2), `n=bk7`,
    ///   `n=fused_silica`, `n=water`;
    /// - `visibility=30m` (or `km`, `cm`, `mm`; a bare number is metres): fog of that
    ///   meteorological optical range, extinction `3.912 / V`, with `albedo=` (default
    ///   1) of it scattering, and `g` [`FOG_G`] unless given; not with `sigma_s`/`sigma_a`.
    ///
    /// Errors name the key and what it must be; the result is validated.
    pub fn parse_spec(spec: &str) -> Result<Medium, SceneError> {
        let bad = |m: String| SceneError::Invalid(format!("medium '{spec}': {m}"));
        let (mut sigma_s, mut sigma_a, mut g, mut n) = (None, None, None, None);
        let (mut visibility, mut albedo) = (None, None);
        let mut dispersion = None;
        for part in spec.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            let Some((key, value)) = part.split_once('=') else {
                return Err(bad(format!("'{part}' is not key=value")));
            };
            let (key, value) = (key.trim(), value.trim());
            let slot = match key {
                "sigma_s" => {
                    sigma_s = Some(per_metre(value).map_err(|m| bad(format!("sigma_s: {m}")))?);
                    continue;
                }
                "sigma_a" => {
                    sigma_a = Some(per_metre(value).map_err(|m| bad(format!("sigma_a: {m}")))?);
                    continue;
                }
                "visibility" => {
                    visibility = Some(metres(value).map_err(|m| bad(format!("visibility: {m}")))?);
                    continue;
                }
                "g" => &mut g,
                "n" if value.parse::<f64>().is_err() => {
                    let d = Dispersion::parse(value).map_err(|m| bad(format!("n: {m}")))?;
                    n = Some(d.n(super::spectrum::D_LINE_NM * 1e-3));
                    dispersion = Some(d);
                    continue;
                }
                "n" => &mut n,
                "albedo" => &mut albedo,
                _ => {
                    return Err(bad(format!(
                        "unknown key '{key}' (known: sigma_s, sigma_a, g, n, visibility, albedo)"
                    )));
                }
            };
            let x: f64 = value
                .parse()
                .map_err(|_| bad(format!("{key} = '{value}' is not a number")))?;
            *slot = Some(x);
        }
        let medium = match visibility {
            Some(v) => {
                if sigma_s.is_some() || sigma_a.is_some() {
                    return Err(bad(
                        "give either visibility (with albedo) or sigma_s/sigma_a, not both".into(),
                    ));
                }
                if !(v.is_finite() && v > 0.0) {
                    return Err(bad(format!("visibility = {v} m must be finite and > 0")));
                }
                let a = albedo.unwrap_or(1.0);
                if !(0.0..=1.0).contains(&a) {
                    return Err(bad(format!("albedo = {a} must be in [0, 1]")));
                }
                Medium::from_visibility(
                    v,
                    a,
                    g.map_or(FOG_G, |g| g as f32),
                    n.unwrap_or(1.0) as f32,
                )
            }
            None => {
                if albedo.is_some() {
                    return Err(bad("albedo is for visibility=; with sigma_s and sigma_a the albedo is sigma_s / (sigma_s + sigma_a)".into()));
                }
                Medium::grey(
                    sigma_s.unwrap_or(0.0) as f32,
                    sigma_a.unwrap_or(0.0) as f32,
                    g.unwrap_or(0.0) as f32,
                    n.unwrap_or(1.0) as f32,
                )
            }
        };
        let medium = Medium {
            dispersion,
            ..medium
        };
        medium.validate(&format!("medium '{spec}'"))?;
        Ok(medium)
    }

    /// The medium of a glTF extras object `{"sigma_s_per_m": s, "sigma_a_per_m": a,
    /// "g": g, "n": n, "density": grid}` (coefficients a number or `[r, g, b]`, per metre;
    /// each key optional: 0, 0, 0 and 1 when left out; `sigma_a_per_m` left out keeps
    /// `sigma_a`, the absorption `KHR_materials_volume` gives; `density` a grid,
    /// [`DensityGrid::from_json`], its file relative to `base`). Unknown keys are refused;
    /// `what` names the object in messages. Not validated (the scene's check does that).
    pub fn from_json(
        value: &serde_json::Value,
        sigma_a: [f32; 3],
        base: Option<&Path>,
        what: &str,
    ) -> Result<Medium, String> {
        let serde_json::Value::Object(map) = value else {
            return Err(format!(
                "{what} = {value}: expected an object {{\"sigma_s_per_m\", \"sigma_a_per_m\", \"g\", \"n\"}}"
            ));
        };
        let mut m = Medium {
            sigma_s_per_m: [0.0; 3],
            sigma_a_per_m: sigma_a,
            g: 0.0,
            n: 1.0,
            dispersion: None,
            density: None,
        };
        for (key, v) in map {
            let number = || {
                v.as_f64()
                    .ok_or_else(|| format!("{what}.{key} = {v}: expected a number"))
            };
            let rgb = || {
                match v {
                    serde_json::Value::Number(x) => x.as_f64().map(|x| [x as f32; 3]),
                    serde_json::Value::Array(a) if a.len() == 3 => {
                        let c: Option<Vec<f64>> = a.iter().map(|x| x.as_f64()).collect();
                        c.map(|c| [c[0] as f32, c[1] as f32, c[2] as f32])
                    }
                    _ => None,
                }
                .ok_or_else(|| {
                    format!("{what}.{key} = {v}: expected a number or [r, g, b] (per metre)")
                })
            };
            match key.as_str() {
                "sigma_s_per_m" => m.sigma_s_per_m = rgb()?,
                "sigma_a_per_m" => m.sigma_a_per_m = rgb()?,
                "g" => m.g = number()? as f32,
                "n" if !v.is_number() => {
                    let d = Dispersion::from_json(v, &format!("{what}.n"))?;
                    m.n = d.n(super::spectrum::D_LINE_NM * 1e-3) as f32;
                    m.dispersion = Some(d);
                }
                "n" => m.n = number()? as f32,
                "density" => {
                    let what = format!("{what}.density");
                    m.density = Some(DensityGrid::from_json(v, base, &what)?);
                }
                _ => {
                    return Err(format!(
                        "{what}: unknown key '{key}' (known: sigma_s_per_m, sigma_a_per_m, g, \
                         n, density)"
                    ));
                }
            }
        }
        Ok(m)
    }

    /// The extras object [`Medium::from_json`] reads, with every field.
    pub fn to_json(&self) -> serde_json::Value {
        let mut v = serde_json::json!({
            "sigma_s_per_m": self.sigma_s_per_m,
            "sigma_a_per_m": self.sigma_a_per_m,
            "g": self.g,
            "n": self.dispersion.as_ref().map_or(serde_json::json!(self.n), Dispersion::to_json),
        });
        if let (Some(d), Some(map)) = (&self.density, v.as_object_mut()) {
            map.insert("density".into(), d.to_json());
        }
        v
    }
}

/// Absorption per metre per channel of glTF `KHR_materials_volume`: light keeps
/// `attenuationColor` after `attenuationDistance` metres, so `sigma_a = -ln(color) / d`
/// (0 for an infinite distance, the default). `None` for a colour outside (0, 1] or a
/// distance that is not > 0.
pub fn volume_absorption_per_m(color: [f32; 3], distance_m: f32) -> Option<[f32; 3]> {
    if !(distance_m > 0.0) || color.iter().any(|&c| !(c > 0.0 && c <= 1.0)) {
        return None;
    }
    if distance_m.is_infinite() {
        return Some([0.0; 3]);
    }
    Some(color.map(|c| (-(c as f64).ln() / distance_m as f64) as f32))
}

/// `KHR_materials_volume`'s `(attenuationColor, attenuationDistance)` for absorption
/// `sigma_a` per metre: the distance over which the most absorbed channel keeps `1/e`
/// (every colour in `[1/e, 1]`, so none rounds to 0); `([1, 1, 1], infinity)` without
/// absorption. [`volume_absorption_per_m`] inverts it.
pub fn volume_attenuation(sigma_a_per_m: [f32; 3]) -> ([f32; 3], f32) {
    let max = sigma_a_per_m.into_iter().fold(0.0f32, f32::max);
    if !(max > 0.0) {
        return ([1.0; 3], f32::INFINITY);
    }
    let d = 1.0 / max as f64;
    (
        sigma_a_per_m.map(|s| (-(s as f64) * d).exp() as f32),
        d as f32,
    )
}

/// A coefficient per metre: `0.05/m`, `5/km`, `0.5/cm`, `2/mm`, or a bare number.
fn per_metre(text: &str) -> Result<f64, String> {
    let (num, scale) = match text.split_once('/') {
        None => (text, 1.0),
        Some((num, unit)) => {
            let scale = match unit.trim() {
                "m" => 1.0,
                "km" => 1e-3,
                "cm" => 1e2,
                "mm" => 1e3,
                u => {
                    return Err(format!(
                        "'{text}': unknown unit '/{u}' (use /m /km /cm /mm)"
                    ));
                }
            };
            (num, scale)
        }
    };
    let x: f64 = num
        .trim()
        .parse()
        .map_err(|_| format!("'{text}': '{}' is not a number", num.trim()))?;
    Ok(x * scale)
}

/// A length in metres: `30m`, `0.2km`, `50cm`, `1mm`, or a bare number (metres).
fn metres(text: &str) -> Result<f64, String> {
    let t = text.trim();
    let split = t
        .char_indices()
        .rev()
        .take_while(|&(_, c)| c.is_ascii_alphabetic())
        .last()
        .map_or(t.len(), |(i, _)| i);
    let (num, unit) = t.split_at(split);
    let scale = match unit {
        "" | "m" => 1.0,
        "km" => 1e3,
        "cm" => 1e-2,
        "mm" => 1e-3,
        u => return Err(format!("'{text}': unknown unit '{u}' (use m km cm mm)")),
    };
    let x: f64 = num
        .trim()
        .parse()
        .map_err(|_| format!("'{text}': '{}' is not a number", num.trim()))?;
    Ok(x * scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spec_with_coefficients() {
        let m = Medium::parse_spec("sigma_s=0.05/m,sigma_a=0.001/m,g=0.9,n=1.0").unwrap();
        assert_eq!(m, Medium::grey(0.05, 0.001, 0.9, 1.0));
        let m = Medium::parse_spec(" sigma_s = 50/km , n=1.33").unwrap();
        assert_eq!(m, Medium::grey(0.05, 0.0, 0.0, 1.33));
        let m = Medium::parse_spec("sigma_a=0.2/cm").unwrap();
        assert!((m.sigma_a_per_m[0] - 20.0).abs() < 1e-5);
    }

    #[test]
    fn visibility_is_the_meteorological_optical_range() {
        let m = Medium::parse_spec("visibility=30m").unwrap();
        let sigma_t = m.sigma_t_per_m()[0] as f64;
        // Contrast after V is 2 %: exp(-sigma_t V) = 0.02.
        assert!(((-sigma_t * 30.0).exp() - 0.02).abs() < 1e-5);
        assert_eq!(m.sigma_a_per_m, [0.0; 3]);
        assert_eq!(m.g, FOG_G);
        assert!((m.visibility_m() - 30.0).abs() < 1e-4);
        let m = Medium::parse_spec("visibility=0.2km,albedo=0.9,g=0.5").unwrap();
        assert!((m.sigma_s_per_m[0] as f64 - 0.9 * 3.912 / 200.0).abs() < 1e-7);
        assert!((m.sigma_a_per_m[0] as f64 - 0.1 * 3.912 / 200.0).abs() < 1e-7);
        assert_eq!(m.g, 0.5);
    }

    #[test]
    fn bad_specs_name_the_key() {
        for (spec, needle) in [
            ("sigma_s=-1/m", "sigma_s_per_m"),
            ("sigma_a=nan", "sigma_a_per_m"),
            ("sigma_s=inf", "sigma_s_per_m"),
            ("g=1", "g = 1"),
            ("g=-1.5", "g = -1.5"),
            ("n=0.9", "n = 0.9"),
            ("n=NaN", "n = NaN"),
            ("visibility=0m", "visibility"),
            ("visibility=-3", "visibility"),
            ("visibility=3furlongs", "visibility"),
            ("visibility=30m,sigma_s=1", "not both"),
            ("visibility=30m,albedo=2", "albedo"),
            ("albedo=0.5", "albedo"),
            ("sigma=1", "unknown key 'sigma'"),
            ("sigma_s", "not key=value"),
            ("sigma_s=1/furlong", "unknown unit"),
            ("g=abc", "g = 'abc'"),
        ] {
            let e = Medium::parse_spec(spec).unwrap_err().to_string();
            assert!(e.contains(needle), "{spec}: {e}");
        }
    }

    #[test]
    fn json_reads_what_it_writes_and_refuses_typos() {
        let m = Medium {
            sigma_s_per_m: [0.1, 0.2, 0.3],
            sigma_a_per_m: [0.01, 0.0, 2.0],
            g: -0.3,
            n: 1.33,
            density: None,
            dispersion: None,
        };
        assert_eq!(Medium::from_json(&m.to_json(), [0.0; 3], None, "x"), Ok(m));
        // A dispersive index: `n` its value at the d line, read back by name or formula.
        for spec in [
            "n=bk7",
            "n=cauchy:1.5:0.004",
            "n=sellmeier:1:0.2:1:0.006:0.02:100",
        ] {
            let m = Medium::parse_spec(spec).unwrap();
            let d = m.dispersion.clone().unwrap();
            assert_eq!(m.n, d.n(0.58756) as f32, "{spec}");
            assert!(m.group_index(0.45) > m.group_index(0.65), "{spec}");
            assert_eq!(Medium::from_json(&m.to_json(), [0.0; 3], None, "x"), Ok(m));
        }
        assert!((Medium::parse_spec("n=bk7").unwrap().n - 1.5168).abs() < 1e-4);
        for bad in ["n=flint", "n=cauchy:1.5", "n=sellmeier:1:2:3"] {
            let e = Medium::parse_spec(bad).unwrap_err().to_string();
            assert!(e.contains("n: "), "{bad}: {e}");
        }
        let v = serde_json::json!({"sigma_s_per_m": 0.5, "g": 0.2});
        let m = Medium::from_json(&v, [0.1, 0.2, 0.3], None, "x").unwrap();
        assert_eq!(m.sigma_s_per_m, [0.5; 3]);
        assert_eq!(m.sigma_a_per_m, [0.1, 0.2, 0.3]);
        let e = Medium::from_json(&serde_json::json!({"sigma_s": 1}), [0.0; 3], None, "mat")
            .unwrap_err();
        assert!(e.contains("mat: unknown key 'sigma_s'"), "{e}");
        let e =
            Medium::from_json(&serde_json::json!({"g": "big"}), [0.0; 3], None, "mat").unwrap_err();
        assert!(e.contains("mat.g"), "{e}");
        let e = Medium::from_json(&serde_json::json!(3), [0.0; 3], None, "mat").unwrap_err();
        assert!(e.contains("expected an object"), "{e}");
    }

    #[test]
    fn volume_attenuation_round_trips() {
        for sigma_a in [[0.5f32, 0.1, 0.0], [3e-4, 2e-4, 1e-4], [40.0, 1.0, 80.0]] {
            let (color, d) = volume_attenuation(sigma_a);
            assert!(color.iter().all(|&c| (0.36..=1.0).contains(&c)));
            let back = volume_absorption_per_m(color, d).unwrap();
            // f32 colours: each channel known to a few ulps of the largest's 1/e.
            let max = sigma_a.into_iter().fold(0.0f32, f32::max);
            for c in 0..3 {
                assert!(
                    (back[c] - sigma_a[c]).abs() <= 1e-6 * max,
                    "{sigma_a:?} -> {back:?}"
                );
            }
        }
        assert_eq!(volume_attenuation([0.0; 3]), ([1.0; 3], f32::INFINITY));
        assert_eq!(
            volume_absorption_per_m([1.0; 3], f32::INFINITY),
            Some([0.0; 3])
        );
        // Light keeping half after 2 m: sigma_a = ln 2 / 2.
        let s = volume_absorption_per_m([0.5, 1.0, 0.25], 2.0).unwrap();
        assert!((s[0] - std::f32::consts::LN_2 / 2.0).abs() < 1e-7);
        assert_eq!(volume_absorption_per_m([0.0, 1.0, 1.0], 1.0), None);
        assert_eq!(volume_absorption_per_m([0.5; 3], 0.0), None);
    }

    #[test]
    fn scaling_keeps_optical_depth() {
        let m = Medium::grey(0.5, 0.25, 0.3, 1.2).scaled(4.0);
        assert_eq!(m, Medium::grey(0.125, 0.0625, 0.3, 1.2));
    }
}
