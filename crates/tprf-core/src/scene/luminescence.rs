//! Luminescence: a surface that stores part of the light it receives and re-emits it
//! later (fluorescence, phosphorescence), the paper's section 7 "interfaces that store
//! energy over time".
//!
//! Of the light arriving at a point, the base colour's fraction is reflected at once by
//! the material's BSDF, and a fraction `Y` (the yield) is absorbed and re-emitted
//! diffusely (Lambertian, radiance `Y E / pi` for irradiance `E`) after a delay drawn from
//! the decay: `sum_k (Y_k / Y) h_k(t)` with `h_k(t) = e^{-t / tau_k} / tau_k` (1 to 3
//! exponential components), each convolved with a rise `e^{-t / tau_r} / tau_r` when a
//! rise time is given. The re-emission goes into the emission colour's band (an RGB
//! colour reduced to the rendered band as the base colour is: [`super::Channel::pick`]).
//! In glTF: the material's extras `{"tprf": {"luminescence": {...}}}` ([`Luminescence::
//! from_json`]); in Mitsuba XML the `tprf_luminescent` BSDF wrapper (docs/mitsuba.md).

use serde_json::{Value, json};

/// Largest number of exponential components of a decay.
pub const MAX_COMPONENTS: usize = 3;

/// One exponential component of a decay.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DecayComponent {
    /// Its yield: the fraction of the received light it re-emits, in [0, 1].
    pub yield_: f32,
    /// Its lifetime `tau`, seconds (> 0, finite).
    pub lifetime_s: f64,
}

/// A material's luminescence (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct Luminescence {
    /// 1 to [`MAX_COMPONENTS`] components; their yields sum to the total yield `Y`.
    pub components: Vec<DecayComponent>,
    /// Rise time `tau_r`, seconds: each component's decay is convolved with
    /// `e^{-t / tau_r} / tau_r` (the excited state filled at that rate). `None`: the
    /// decay starts at its peak.
    pub rise_s: Option<f64>,
    /// Linear RGB colour of the re-emitted light, each in [0, 1]: the band's share of
    /// the re-emission ([`super::Channel::pick`]). White by default.
    pub emission_color: [f32; 3],
}

impl Luminescence {
    /// One lifetime `lifetime_s` with yield `yield_`, white, no rise.
    pub fn single(yield_: f32, lifetime_s: f64) -> Luminescence {
        Luminescence {
            components: vec![DecayComponent { yield_, lifetime_s }],
            rise_s: None,
            emission_color: [1.0; 3],
        }
    }

    /// The total yield `Y = sum_k Y_k`.
    pub fn yield_total(&self) -> f32 {
        self.components.iter().map(|c| c.yield_).sum()
    }

    /// Check the luminescence of material `material` with base colour `base_rgb`:
    /// 1 to 3 components, yields finite in [0, 1], lifetimes and the rise time finite and
    /// positive, the emission colour in [0, 1], and each channel's base colour plus the
    /// yield at most 1 (light is not made at a surface). The error names the material and field.
    pub fn check(&self, material: &str, base_rgb: [f32; 3]) -> Result<(), String> {
        let what = format!("material '{material}': luminescence");
        let n = self.components.len();
        if n == 0 || n > MAX_COMPONENTS {
            return Err(format!(
                "{what}: {n} decay components (give 1 to {MAX_COMPONENTS})"
            ));
        }
        for (k, c) in self.components.iter().enumerate() {
            if !(c.yield_.is_finite() && (0.0..=1.0).contains(&c.yield_)) {
                return Err(format!(
                    "{what}: component {k}'s yield {} must be in [0, 1]",
                    c.yield_
                ));
            }
            if !(c.lifetime_s.is_finite() && c.lifetime_s > 0.0) {
                return Err(format!(
                    "{what}: component {k}'s lifetime_s {} must be finite and > 0 seconds",
                    c.lifetime_s
                ));
            }
        }
        if let Some(r) = self.rise_s
            && !(r.is_finite() && r > 0.0)
        {
            return Err(format!("{what}: rise_s {r} must be finite and > 0 seconds"));
        }
        if self
            .emission_color
            .iter()
            .any(|c| !(c.is_finite() && (0.0..=1.0).contains(c)))
        {
            return Err(format!(
                "{what}: emission_color {:?} must be in [0, 1] per channel",
                self.emission_color
            ));
        }
        let y = self.yield_total();
        for (name, b) in ["red", "green", "blue"].iter().zip(base_rgb) {
            if b + y > 1.0 + 1e-6 {
                return Err(format!(
                    "{what}: base colour {name} {b} plus yield {y} is {} > 1: the surface \
                     would give back more light than it receives (lower the base colour or \
                     the yield)",
                    b + y
                ));
            }
        }
        Ok(())
    }

    /// Read glTF extras' `tprf.luminescence` object: `{"yield": Y, "lifetime_s": tau}`
    /// or `{"components": [[Y_k, tau_k_s], ...]}` (the yields summing to `"yield"` when
    /// both are given), optional `"rise_s"` and `"emission_color": [r, g, b]`. `what`
    /// names the object in errors. Ranges are checked by [`Luminescence::check`].
    pub fn from_json(v: &Value, what: &str) -> Result<Luminescence, String> {
        let Some(obj) = v.as_object() else {
            return Err(format!("{what} = {v}: expected an object"));
        };
        const FIELDS: [&str; 5] = [
            "yield",
            "lifetime_s",
            "components",
            "rise_s",
            "emission_color",
        ];
        if let Some(k) = obj.keys().find(|k| !FIELDS.contains(&k.as_str())) {
            return Err(format!(
                "{what}: unknown field '{k}' (yield, lifetime_s, components, rise_s, \
                 emission_color)"
            ));
        }
        let number = |name: &str| -> Result<Option<f64>, String> {
            match obj.get(name) {
                None => Ok(None),
                Some(x) => x
                    .as_f64()
                    .map(Some)
                    .ok_or_else(|| format!("{what}: {name} = {x} is not a number")),
            }
        };
        let yield_ = number("yield")?;
        let lifetime = number("lifetime_s")?;
        let components = match (obj.get("components"), lifetime) {
            (Some(_), Some(_)) => {
                return Err(format!(
                    "{what}: give either lifetime_s (with yield) or components, not both"
                ));
            }
            (Some(list), None) => {
                let Some(list) = list.as_array() else {
                    return Err(format!(
                        "{what}: components = {list}: expected [[yield, lifetime_s], ...]"
                    ));
                };
                let mut out = Vec::with_capacity(list.len());
                for (k, c) in list.iter().enumerate() {
                    let pair = c.as_array().filter(|p| p.len() == 2);
                    let nums = pair.and_then(|p| Some((p[0].as_f64()?, p[1].as_f64()?)));
                    let Some((y, tau)) = nums else {
                        return Err(format!(
                            "{what}: components[{k}] = {c}: expected [yield, lifetime_s]"
                        ));
                    };
                    out.push(DecayComponent {
                        yield_: y as f32,
                        lifetime_s: tau,
                    });
                }
                if let Some(y) = yield_ {
                    let sum: f64 = out.iter().map(|c| c.yield_ as f64).sum();
                    if (sum - y).abs() > 1e-6 * y.abs().max(1.0) {
                        return Err(format!(
                            "{what}: the components' yields sum to {sum}, not yield {y}"
                        ));
                    }
                }
                out
            }
            (None, Some(tau)) => {
                let Some(y) = yield_ else {
                    return Err(format!("{what}: lifetime_s needs a yield"));
                };
                vec![DecayComponent {
                    yield_: y as f32,
                    lifetime_s: tau,
                }]
            }
            (None, None) => {
                return Err(format!(
                    "{what}: give yield and lifetime_s, or components [[yield, lifetime_s], ...]"
                ));
            }
        };
        let emission_color = match obj.get("emission_color") {
            None => [1.0; 3],
            Some(c) => {
                let rgb = c
                    .as_array()
                    .filter(|a| a.len() == 3)
                    .and_then(|a| Some([a[0].as_f64()?, a[1].as_f64()?, a[2].as_f64()?]));
                match rgb {
                    Some(rgb) => rgb.map(|x| x as f32),
                    None => {
                        return Err(format!("{what}: emission_color = {c}: expected [r, g, b]"));
                    }
                }
            }
        };
        Ok(Luminescence {
            components,
            rise_s: number("rise_s")?,
            emission_color,
        })
    }

    /// The glTF extras object [`Luminescence::from_json`] reads back.
    pub fn to_json(&self) -> Value {
        let components: Vec<Value> = self
            .components
            .iter()
            .map(|c| json!([c.yield_, c.lifetime_s]))
            .collect();
        let mut v = json!({
            "yield": self.yield_total(),
            "components": components,
            "emission_color": self.emission_color,
        });
        if let (Some(r), Some(o)) = (self.rise_s, v.as_object_mut()) {
            o.insert("rise_s".into(), json!(r));
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_forms_read_and_round_trip() {
        let one = Luminescence::from_json(&json!({"yield": 0.4, "lifetime_s": 4e-9}), "m").unwrap();
        assert_eq!(one, Luminescence::single(0.4, 4e-9));
        let two = Luminescence::from_json(
            &json!({"components": [[0.1, 1e-9], [0.3, 4e-9]], "rise_s": 1e-10,
                    "emission_color": [0.0, 1.0, 0.5]}),
            "m",
        )
        .unwrap();
        assert_eq!(two.components.len(), 2);
        assert!((two.yield_total() - 0.4).abs() < 1e-6);
        assert_eq!(two.rise_s, Some(1e-10));
        assert_eq!(Luminescence::from_json(&two.to_json(), "m").unwrap(), two);
        assert_eq!(Luminescence::from_json(&one.to_json(), "m").unwrap(), one);
    }

    #[test]
    fn bad_input_is_refused_naming_the_field() {
        let err = |v: Value| Luminescence::from_json(&v, "materials[2] extras").unwrap_err();
        assert!(err(json!({"yield": 0.4})).contains("lifetime_s"));
        assert!(err(json!({"yield": 0.4, "lifetime_s": "4ns"})).contains("lifetime_s"));
        assert!(err(json!({"yield": 0.4, "lifetime": 4e-9})).contains("unknown field 'lifetime'"));
        assert!(err(json!({"components": [[0.4]]})).contains("components[0]"));
        assert!(
            err(json!({"yield": 0.5, "components": [[0.1, 1e-9], [0.3, 4e-9]]})).contains("sum to")
        );
        let check = |l: Luminescence, base: f32| l.check("phosphor", [base; 3]);
        for tau in [0.0, -1e-9, f64::NAN, f64::INFINITY] {
            let e = check(Luminescence::single(0.3, tau), 0.2).unwrap_err();
            assert!(e.contains("'phosphor'") && e.contains("lifetime_s"), "{e}");
        }
        let e = check(Luminescence::single(0.5, 1e-9), 0.6).unwrap_err();
        assert!(
            e.contains("base colour red 0.6") && e.contains("yield 0.5"),
            "{e}"
        );
        assert!(check(Luminescence::single(0.4, 1e-9), 0.6).is_ok());
        let mut l = Luminescence::single(0.3, 1e-9);
        l.rise_s = Some(0.0);
        assert!(check(l, 0.0).unwrap_err().contains("rise_s"));
        let mut l = Luminescence::single(0.3, 1e-9);
        l.components = vec![l.components[0]; 4];
        assert!(check(l, 0.0).unwrap_err().contains("4 decay components"));
        let mut l = Luminescence::single(f32::NAN, 1e-9);
        assert!(check(l.clone(), 0.0).unwrap_err().contains("yield"));
        l = Luminescence::single(0.3, 1e-9);
        l.emission_color = [2.0, 0.0, 0.0];
        assert!(check(l, 0.0).unwrap_err().contains("emission_color"));
    }
}
