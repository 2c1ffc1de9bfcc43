//! The scene-wide medium as the window edits it: fog given by its visibility (the
//! meteorological optical range `V`, extinction `3.912 / V` per metre), its
//! single-scattering albedo and its Henyey-Greenstein `g`, written as the request's
//! `medium` spec (`visibility=V m,albedo=a,g=g,n=n`). egui-free, tested without a window.

use super::camera::number_text;
use tprf_core::scene::Medium;

/// Fog as the window sets it. `n` is the scene medium's refractive index, kept as it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fog {
    /// Meteorological optical range, metres: extinction `3.912 / visibility_m` per metre.
    pub visibility_m: f64,
    /// Single-scattering albedo `sigma_s / sigma_t`, in [0, 1].
    pub albedo: f64,
    /// Henyey-Greenstein asymmetry, in (-1, 1).
    pub g: f64,
    /// Refractive index (not edited).
    pub n: f64,
}

impl Fog {
    /// The fog of a (non-clear) medium: the visibility of its largest channel's
    /// extinction, that channel's albedo, its `g` and `n`. `None` for a clear medium, and
    /// for a heterogeneous one (a density grid has no one visibility to edit).
    pub fn of_medium(m: &Medium) -> Option<Fog> {
        if m.density.is_some() {
            return None;
        }
        let t = m.sigma_t_per_m();
        let c = (0..3).fold(0, |a, c| if t[c] > t[a] { c } else { a });
        let sigma_t = f64::from(t[c]);
        (sigma_t > 0.0 && sigma_t.is_finite()).then(|| Fog {
            visibility_m: m.visibility_m(),
            albedo: f64::from(m.sigma_s_per_m[c]) / sigma_t,
            g: f64::from(m.g),
            n: f64::from(m.n),
        })
    }

    /// The request's `medium` spec for this fog (numbers written exactly, so the
    /// request's extinction is `3.912 / visibility_m`).
    pub fn spec(&self) -> String {
        format!(
            "visibility={}m,albedo={},g={},n={}",
            self.visibility_m, self.albedo, self.g, self.n
        )
    }
}

/// The fog's fields as typed, and the fog they were filled from.
#[derive(Clone, Debug, Default)]
pub struct FogText {
    pub visibility: String,
    pub albedo: String,
    pub g: String,
    shown: Option<Fog>,
}

impl FogText {
    /// Fill the fields from `fog` when it is not the one they show; what is being typed
    /// for the same fog stays.
    pub fn follow(&mut self, fog: &Fog) {
        if self.shown.as_ref() != Some(fog) {
            *self = FogText {
                visibility: number_text(fog.visibility_m),
                albedo: number_text(fog.albedo),
                g: number_text(fog.g),
                shown: Some(*fog),
            };
        }
    }

    /// The fog the fields were filled from.
    pub fn shown(&self) -> Option<Fog> {
        self.shown
    }

    /// Whether a field differs from the fog it was filled from.
    pub fn edited(&self) -> bool {
        self.shown.is_some_and(|f| {
            self.visibility != number_text(f.visibility_m)
                || self.albedo != number_text(f.albedo)
                || self.g != number_text(f.g)
        })
    }

    /// The fog typed: each edited field parsed and checked, each other one the shown
    /// fog's exact value (the fields round to 4 decimals). The error names the field.
    pub fn parse(&self) -> Result<Fog, String> {
        let Some(f) = self.shown else {
            return Err("fog: the scene is still loading".into());
        };
        let field = |text: &str, exact: f64, parse: fn(&str) -> Result<f64, String>| {
            if text == number_text(exact) {
                Ok(exact)
            } else {
                parse(text)
            }
        };
        Ok(Fog {
            visibility_m: field(&self.visibility, f.visibility_m, parse_visibility_m)?,
            albedo: field(&self.albedo, f.albedo, parse_albedo)?,
            g: field(&self.g, f.g, parse_g)?,
            n: f.n,
        })
    }
}

/// A visibility typed in metres (`50`, `50 m`; `0.2 km`), finite and > 0.
pub fn parse_visibility_m(text: &str) -> Result<f64, String> {
    let t = text.trim();
    let (number, scale) = if let Some(n) = t.strip_suffix("km") {
        (n, 1e3)
    } else if let Some(n) = t.strip_suffix('m') {
        (n, 1.0)
    } else {
        (t, 1.0)
    };
    match number.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && (v * scale).is_finite() => Ok(v * scale),
        _ => Err(format!(
            "fog visibility '{text}': give a distance in metres > 0 (50, 50 m, 0.2 km)"
        )),
    }
}

/// An albedo typed: a number in [0, 1].
pub fn parse_albedo(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(a) if (0.0..=1.0).contains(&a) => Ok(a),
        _ => Err(format!(
            "fog albedo '{text}': give the scattered fraction of the extinction, in [0, 1]"
        )),
    }
}

/// A Henyey-Greenstein `g` typed: a number in (-1, 1).
pub fn parse_g(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(g) if g > -1.0 && g < 1.0 => Ok(g),
        _ => Err(format!(
            "fog g '{text}': give the Henyey-Greenstein asymmetry, in (-1, 1) (0 isotropic, \
             0.9 fog's forward peak)"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tprf_core::request::RenderRequest;
    use tprf_core::scene::medium::MOR_EXTINCTION;

    /// The spec of a fog is the request's medium with extinction 3.912 / V exactly (in
    /// the f32 the renderer holds), the albedo's share scattering and g and n kept.
    #[test]
    fn the_spec_gives_the_request_the_fogs_extinction() {
        for (v, a, g) in [(50.0, 1.0, 0.9), (12.345, 0.8, 0.0), (3000.0, 0.25, -0.3)] {
            let fog = Fog {
                visibility_m: v,
                albedo: a,
                g,
                n: 1.0,
            };
            let r = RenderRequest {
                medium: Some(fog.spec()),
                ..RenderRequest::new("builtin:fog")
            };
            let m = r.medium_override().unwrap().unwrap().unwrap();
            let sigma_t = MOR_EXTINCTION / v;
            assert_eq!(m.sigma_s_per_m, [(sigma_t * a) as f32; 3]);
            assert_eq!(m.sigma_a_per_m, [(sigma_t * (1.0 - a)) as f32; 3]);
            assert_eq!(m.g, g as f32);
            let back = Fog::of_medium(&m).unwrap();
            assert!((back.visibility_m - v).abs() < 1e-5 * v, "{back:?}");
            assert!((back.albedo - a).abs() < 1e-6, "{back:?}");
        }
        assert_eq!(Fog::of_medium(&Medium::grey(0.0, 0.0, 0.5, 1.33)), None);
    }

    /// Fields not edited keep the shown fog's exact values; bad ones name the field.
    #[test]
    fn typed_fog_is_parsed_and_bad_values_are_named() {
        let fog = Fog {
            visibility_m: 3.912 / f64::from(3.912f32 / 50.0),
            albedo: 1.0,
            g: f64::from(0.9f32),
            n: 1.0,
        };
        let mut t = FogText::default();
        t.follow(&fog);
        assert_eq!((t.visibility.as_str(), t.g.as_str()), ("50", "0.9"));
        assert!(!t.edited());
        assert_eq!(t.parse(), Ok(fog));
        t.visibility = "0.2 km".into();
        assert!(t.edited());
        assert_eq!(t.parse().unwrap().visibility_m, 200.0);
        assert_eq!(t.parse().unwrap().g, fog.g);
        for (field, text, named) in [
            ("v", "-5", "fog visibility"),
            ("v", "0", "fog visibility"),
            ("v", "fog", "fog visibility"),
            ("v", "inf", "fog visibility"),
            ("a", "1.5", "fog albedo"),
            ("a", "NaN", "fog albedo"),
            ("g", "1", "fog g"),
            ("g", "-1", "fog g"),
        ] {
            let mut t = t.clone();
            match field {
                "v" => t.visibility = text.into(),
                "a" => t.albedo = text.into(),
                _ => t.g = text.into(),
            }
            let e = t.parse().unwrap_err();
            assert!(e.starts_with(named), "{text}: {e}");
        }
    }
}
