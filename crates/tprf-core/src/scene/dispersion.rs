//! Refractive indices that depend on the wavelength: the phase index `n(lambda)` that
//! refraction (Snell's law, Fresnel) reads, and the group index
//! `n_g(lambda) = n - lambda dn/dlambda` at which a pulse's energy travels, `c / n_g`:
//! the time a path takes through a dispersive region (docs/dispersion.md).
//!
//! Models, wavelengths in micrometres:
//! - Cauchy: `n = A + B / lambda^2` (`B` in um^2);
//! - Sellmeier: `n^2 = 1 + sum_i B_i lambda^2 / (lambda^2 - C_i)` (`C_i` in um^2), three
//!   terms on the command line, up to four in the named materials;
//! - named: `bk7` (SCHOTT N-BK7, its data sheet's Sellmeier coefficients), `fused_silica`
//!   (Malitson, "Interspecimen comparison of the refractive index of fused silica", JOSA
//!   55, 1205, 1965), `water` (Daimon & Masumura, "Measurement of the refractive index
//!   of distilled water from the near-infrared region to the ultraviolet region",
//!   Applied Optics 46, 3811, 2007: their four-term fit at 20 °C).
//!
//! `dn/dlambda` is the formulas' own derivative, not a difference quotient.

/// A refractive index as a function of wavelength.
#[derive(Clone, Debug, PartialEq)]
pub enum Dispersion {
    /// `n = a + b_um2 / lambda^2`.
    Cauchy { a: f64, b_um2: f64 },
    /// `n^2 = 1 + sum_i b[i] lambda^2 / (lambda^2 - c_um2[i])`; unused terms have `b = 0`.
    Sellmeier { b: [f64; 4], c_um2: [f64; 4] },
}

/// The named materials, each with its Sellmeier coefficients.
pub const NAMED: [(&str, Dispersion); 3] = [
    (
        "bk7",
        Dispersion::Sellmeier {
            b: [1.039_612_12, 0.231_792_344, 1.010_469_45, 0.0],
            c_um2: [0.006_000_698_67, 0.020_017_914_4, 103.560_653, 0.0],
        },
    ),
    (
        "fused_silica",
        Dispersion::Sellmeier {
            b: [0.696_166_3, 0.407_942_6, 0.897_479_4, 0.0],
            // Malitson gives the resonances as wavelengths: 0.0684043, 0.1162414, 9.896161 um.
            c_um2: [
                0.068_404_3 * 0.068_404_3,
                0.116_241_4 * 0.116_241_4,
                9.896_161 * 9.896_161,
                0.0,
            ],
        },
    ),
    (
        "water",
        Dispersion::Sellmeier {
            b: [
                5.684_027_565e-1,
                1.726_177_391e-1,
                2.086_189_578e-2,
                1.130_748_688e-1,
            ],
            c_um2: [
                5.101_829_712e-3,
                1.821_153_936e-2,
                2.620_722_293e-2,
                1.069_792_721e1,
            ],
        },
    ),
];

impl Dispersion {
    /// The named material `name` (`bk7`, `fused_silica` or `fused-silica`, `water`; case
    /// ignored).
    pub fn named(name: &str) -> Option<Dispersion> {
        let key = name.trim().to_ascii_lowercase().replace('-', "_");
        NAMED
            .iter()
            .find(|(n, _)| *n == key)
            .map(|(_, d)| d.clone())
    }

    /// The phase index at `lambda_um` micrometres.
    pub fn n(&self, lambda_um: f64) -> f64 {
        match self {
            Dispersion::Cauchy { a, b_um2 } => a + b_um2 / (lambda_um * lambda_um),
            Dispersion::Sellmeier { b, c_um2 } => {
                let l2 = lambda_um * lambda_um;
                let sum: f64 = (0..4)
                    .filter(|&i| b[i] != 0.0)
                    .map(|i| b[i] * l2 / (l2 - c_um2[i]))
                    .sum();
                (1.0 + sum).sqrt()
            }
        }
    }

    /// `dn/dlambda` at `lambda_um`, per micrometre: Cauchy `-2 B / lambda^3`; Sellmeier
    /// `(1 / 2n) d(n^2)/dlambda` with `d(n^2)/dlambda = -sum_i 2 B_i C_i lambda /
    /// (lambda^2 - C_i)^2`.
    pub fn dn_dlambda_per_um(&self, lambda_um: f64) -> f64 {
        match self {
            Dispersion::Cauchy { b_um2, .. } => -2.0 * b_um2 / lambda_um.powi(3),
            Dispersion::Sellmeier { b, c_um2 } => {
                let l2 = lambda_um * lambda_um;
                let dn2: f64 = (0..4)
                    .filter(|&i| b[i] != 0.0)
                    .map(|i| -2.0 * b[i] * c_um2[i] * lambda_um / (l2 - c_um2[i]).powi(2))
                    .sum();
                dn2 / (2.0 * self.n(lambda_um))
            }
        }
    }

    /// The group index `n_g = n - lambda dn/dlambda` at `lambda_um`: a pulse travels at
    /// `c / n_g`.
    pub fn group_index(&self, lambda_um: f64) -> f64 {
        self.n(lambda_um) - lambda_um * self.dn_dlambda_per_um(lambda_um)
    }

    /// Parse `cauchy:A:B` (B in um^2), `sellmeier:B1:B2:B3:C1:C2:C3` (C in um^2) or a
    /// name ([`Dispersion::named`]). Errors say what was expected.
    pub fn parse(spec: &str) -> Result<Dispersion, String> {
        let parts: Vec<&str> = spec.split(':').map(str::trim).collect();
        let numbers = |want: usize| -> Result<Vec<f64>, String> {
            if parts.len() != want + 1 {
                return Err(format!(
                    "'{spec}': {} takes {want} numbers after it, separated by ':'",
                    parts[0]
                ));
            }
            parts[1..]
                .iter()
                .map(|p| {
                    p.parse::<f64>()
                        .ok()
                        .filter(|x| x.is_finite())
                        .ok_or_else(|| format!("'{spec}': '{p}' is not a finite number"))
                })
                .collect()
        };
        let d = match parts[0].to_ascii_lowercase().as_str() {
            "cauchy" => {
                let v = numbers(2)?;
                Dispersion::Cauchy {
                    a: v[0],
                    b_um2: v[1],
                }
            }
            "sellmeier" => {
                let v = numbers(6)?;
                Dispersion::Sellmeier {
                    b: [v[0], v[1], v[2], 0.0],
                    c_um2: [v[3], v[4], v[5], 0.0],
                }
            }
            name => Dispersion::named(name).ok_or_else(|| {
                format!(
                    "'{spec}' is not a dispersion (cauchy:A:B, sellmeier:B1:B2:B3:C1:C2:C3, \
                     or one of bk7, fused_silica, water)"
                )
            })?,
        };
        d.validate()?;
        Ok(d)
    }

    /// The dispersion of a glTF extras value: `{"cauchy": [A, B_um2]}`, `{"sellmeier":
    /// [B1, B2, B3, C1, C2, C3]}` or a name `"bk7"`. `what` names it in messages.
    pub fn from_json(v: &serde_json::Value, what: &str) -> Result<Dispersion, String> {
        let numbers = |a: &serde_json::Value, want: usize| -> Option<Vec<f64>> {
            let a = a.as_array()?;
            (a.len() == want)
                .then(|| a.iter().map(|x| x.as_f64()).collect::<Option<Vec<f64>>>())
                .flatten()
        };
        let d = match v {
            serde_json::Value::String(name) => Dispersion::named(name).ok_or_else(|| {
                format!("{what} = \"{name}\": known names are bk7, fused_silica, water")
            })?,
            serde_json::Value::Object(map) if map.len() == 1 => {
                if let Some(c) = map.get("cauchy") {
                    let v = numbers(c, 2)
                        .ok_or_else(|| format!("{what}.cauchy = {c}: expected [A, B_um2]"))?;
                    Dispersion::Cauchy {
                        a: v[0],
                        b_um2: v[1],
                    }
                } else if let Some(s) = map.get("sellmeier") {
                    let v = numbers(s, 6).ok_or_else(|| {
                        format!(
                            "{what}.sellmeier = {s}: expected [B1, B2, B3, C1_um2, C2_um2, C3_um2]"
                        )
                    })?;
                    Dispersion::Sellmeier {
                        b: [v[0], v[1], v[2], 0.0],
                        c_um2: [v[3], v[4], v[5], 0.0],
                    }
                } else {
                    return Err(format!(
                        "{what} = {v}: expected {{\"cauchy\": [A, B_um2]}} or {{\"sellmeier\": [...]}}"
                    ));
                }
            }
            _ => {
                return Err(format!(
                    "{what} = {v}: expected {{\"cauchy\": [A, B_um2]}}, {{\"sellmeier\": [B1, B2, \
                     B3, C1, C2, C3]}} or a name (bk7, fused_silica, water)"
                ));
            }
        };
        d.validate().map_err(|e| format!("{what}: {e}"))?;
        Ok(d)
    }

    /// The JSON [`Dispersion::from_json`] reads back.
    pub fn to_json(&self) -> serde_json::Value {
        if let Some((name, _)) = NAMED.iter().find(|(_, d)| d == self) {
            return serde_json::json!(name);
        }
        match self {
            Dispersion::Cauchy { a, b_um2 } => serde_json::json!({"cauchy": [a, b_um2]}),
            Dispersion::Sellmeier { b, c_um2 } => serde_json::json!({
                "sellmeier": [b[0], b[1], b[2], c_um2[0], c_um2[1], c_um2[2]]
            }),
        }
    }

    /// In words: `cauchy:1.5:0.0042`, `bk7`.
    pub fn describe(&self) -> String {
        if let Some((name, _)) = NAMED.iter().find(|(_, d)| d == self) {
            return (*name).to_string();
        }
        match self {
            Dispersion::Cauchy { a, b_um2 } => format!("cauchy:{a}:{b_um2}"),
            Dispersion::Sellmeier { b, c_um2 } => format!(
                "sellmeier:{}:{}:{}:{}:{}:{}",
                b[0], b[1], b[2], c_um2[0], c_um2[1], c_um2[2]
            ),
        }
    }

    /// Refuse an index that is not finite and at least 1, or a group index below 1, at
    /// 360, 587.56 and 830 nm (the ends of the bands and the d line), or a Sellmeier
    /// resonance inside that range.
    pub fn validate(&self) -> Result<(), String> {
        if let Dispersion::Sellmeier { c_um2, b } = self {
            for i in 0..4 {
                let l = c_um2[i].max(0.0).sqrt();
                if b[i] != 0.0 && (0.36..=0.83).contains(&l) {
                    return Err(format!(
                        "sellmeier term {} has its resonance at {} nm, inside the visible \
                         bands (C must be outside [0.1296, 0.6889] um^2)",
                        i + 1,
                        l * 1e3
                    ));
                }
            }
        }
        for l in [0.36, super::spectrum::D_LINE_NM * 1e-3, 0.83] {
            let (n, ng) = (self.n(l), self.group_index(l));
            if !(n.is_finite() && n >= 1.0 && ng.is_finite() && ng >= 1.0) {
                return Err(format!(
                    "{} gives n = {n}, n_g = {ng} at {} nm: both must be finite and >= 1",
                    self.describe(),
                    l * 1e3
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Catalogue values: N-BK7 `n_d = 1.5168`, `n_F = 1.52238`, `n_C = 1.51432` (SCHOTT);
    /// fused silica `n_d = 1.4585` (Malitson); water `n_D = 1.3334` at 589.3 nm.
    #[test]
    fn named_indices_match_their_catalogues() {
        let bk7 = Dispersion::named("BK7").unwrap();
        assert!((bk7.n(0.587_56) - 1.5168).abs() < 5e-5);
        assert!((bk7.n(0.486_13) - 1.52238).abs() < 5e-5);
        assert!((bk7.n(0.656_27) - 1.51432).abs() < 5e-5);
        let silica = Dispersion::named("fused-silica").unwrap();
        assert!((silica.n(0.587_56) - 1.4585).abs() < 5e-5);
        let water = Dispersion::named("water").unwrap();
        assert!((water.n(0.5893) - 1.3334).abs() < 3e-4);
    }

    /// The analytic `dn/dlambda` against a central difference of `n`, and the group index
    /// above the phase index in normal dispersion.
    #[test]
    fn derivative_matches_a_difference_quotient() {
        let models = [
            Dispersion::parse("cauchy:1.5046:0.0042").unwrap(),
            Dispersion::parse("bk7").unwrap(),
            Dispersion::parse("water").unwrap(),
            Dispersion::parse("fused_silica").unwrap(),
        ];
        for d in &models {
            for l in [0.4, 0.55, 0.7] {
                let h = 1e-5;
                let fd = (d.n(l + h) - d.n(l - h)) / (2.0 * h);
                let an = d.dn_dlambda_per_um(l);
                assert!(
                    (fd - an).abs() < 1e-6 * an.abs().max(1e-3),
                    "{d:?} at {l}: {fd} {an}"
                );
                assert!(d.group_index(l) > d.n(l));
            }
        }
    }

    #[test]
    fn specs_parse_and_refuse() {
        assert_eq!(
            Dispersion::parse("cauchy:1.5:0.004").unwrap(),
            Dispersion::Cauchy {
                a: 1.5,
                b_um2: 0.004
            }
        );
        let s = Dispersion::parse(
            "sellmeier:1.03961212:0.231792344:1.01046945:0.00600069867:0.0200179144:103.560653",
        )
        .unwrap();
        assert!((s.n(0.58756) - 1.5168).abs() < 5e-5);
        for bad in [
            "cauchy:1.5",
            "cauchy:x:1",
            "glass",
            "cauchy:0.5:0",
            "sellmeier:1:0:0:0.25:0:0",
        ] {
            assert!(Dispersion::parse(bad).is_err(), "{bad}");
        }
        let j = serde_json::json!({"cauchy": [1.5, 0.004]});
        assert_eq!(
            Dispersion::from_json(&j, "n").unwrap(),
            Dispersion::parse("cauchy:1.5:0.004").unwrap()
        );
        for d in [
            Dispersion::parse("bk7").unwrap(),
            Dispersion::parse("cauchy:1.5:0.004").unwrap(),
        ] {
            assert_eq!(Dispersion::from_json(&d.to_json(), "n").unwrap(), d);
        }
        assert!(Dispersion::from_json(&serde_json::json!({"cauchy": [1.5]}), "n").is_err());
    }
}
