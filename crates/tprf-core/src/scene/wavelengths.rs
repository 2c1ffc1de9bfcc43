//! Several bands in one render: the list of wavelengths a spectral render records
//! (`--wavelengths 450nm,550nm,650nm`, `--spectrum 400nm:700nm:31`, the request's
//! `wavelengths`), and the weights that make their luminance.

use super::spectrum::Wavelength;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// The most bands one render may record.
pub const MAX_BANDS: usize = 1000;

impl Serialize for Wavelength {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.name())
    }
}

impl<'de> Deserialize<'de> for Wavelength {
    /// `"550nm"`, `"0.55um"` or a number of nanometres.
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Wavelength, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Text {
            Nm(f64),
            Text(String),
        }
        match Text::deserialize(d)? {
            Text::Nm(nm) => Wavelength::from_nm(nm),
            Text::Text(t) => Wavelength::parse(&t),
        }
        .map_err(serde::de::Error::custom)
    }
}

/// `450nm,550nm,650nm`: wavelengths separated by commas, in the order given.
pub fn parse_list(text: &str) -> Result<Vec<Wavelength>, String> {
    let list = text
        .split(',')
        .map(Wavelength::parse)
        .collect::<Result<Vec<_>, _>>()?;
    check_list(&list)?;
    Ok(list)
}

/// `400nm:700nm:31`: `N` wavelengths evenly spaced from the first to the last, both
/// included (`lambda_k = a + k (b - a) / (N - 1)`), `N` at least 2, `a < b`.
pub fn parse_range(text: &str) -> Result<Vec<Wavelength>, String> {
    let parts: Vec<&str> = text.split(':').collect();
    let [a, b, n] = parts[..] else {
        return Err(format!(
            "'{text}' is not FIRST:LAST:COUNT (e.g. 400nm:700nm:31)"
        ));
    };
    let (a, b) = (Wavelength::parse(a)?, Wavelength::parse(b)?);
    let n: usize = n
        .trim()
        .parse()
        .map_err(|_| format!("'{n}' is not a count of wavelengths"))?;
    if !(2..=MAX_BANDS).contains(&n) {
        return Err(format!(
            "{n} wavelengths: the count must be in 2..={MAX_BANDS}"
        ));
    }
    if a.nm() >= b.nm() {
        return Err(format!(
            "{} to {}: the first wavelength must be below the last",
            a.name(),
            b.name()
        ));
    }
    let step = (b.nm() - a.nm()) / (n - 1) as f64;
    let list = (0..n)
        .map(|k| {
            Wavelength::from_nm(if k + 1 == n {
                b.nm()
            } else {
                a.nm() + k as f64 * step
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    check_list(&list)?;
    Ok(list)
}

/// A list of bands: at most [`MAX_BANDS`], none twice.
pub fn check_list(list: &[Wavelength]) -> Result<(), String> {
    if list.len() > MAX_BANDS {
        return Err(format!("{} wavelengths: at most {MAX_BANDS}", list.len()));
    }
    for (i, w) in list.iter().enumerate() {
        if list[..i].contains(w) {
            return Err(format!("{} is given twice", w.name()));
        }
    }
    Ok(())
}

/// The weight of each band (in the list's order) in the luminance of the bands, the
/// normalised CIE 1931 `Y`:
/// `Y = sum_k w_k L_k`, `w_k = ybar(lambda_k) D_k / sum_j ybar(lambda_j) D_j`,
/// the trapezoid rule for `int ybar(lambda) L(lambda) dlambda / int ybar(lambda)
/// dlambda` over the sampled wavelengths sorted (`D_k` half the distance between the
/// band's neighbours, half the distance to its one neighbour at either end; one band:
/// weight 1). The weights sum to 1, so a flat spectrum's luminance is its value (a grey
/// scene's luminance cube is each band's). Dimensionless.
pub fn luminance_weights(list: &[Wavelength]) -> Vec<f64> {
    if list.len() == 1 {
        return vec![1.0];
    }
    let mut order: Vec<usize> = (0..list.len()).collect();
    order.sort_by(|&i, &j| list[i].nm().total_cmp(&list[j].nm()));
    let mut w = vec![0.0; list.len()];
    for (pos, &k) in order.iter().enumerate() {
        let lo = list[order[pos.saturating_sub(1)]].nm();
        let hi = list[order[(pos + 1).min(order.len() - 1)]].nm();
        w[k] = list[k].ybar() * 0.5 * (hi - lo);
    }
    let sum: f64 = w.iter().sum();
    if sum > 0.0 {
        w.iter_mut().for_each(|v| *v /= sum);
    } else {
        // ybar vanishes at every sample (none in 360-830 nm does): equal weights.
        w.fill(1.0 / list.len() as f64);
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nm(list: &[Wavelength]) -> Vec<f64> {
        list.iter().map(|w| w.nm()).collect()
    }

    #[test]
    fn lists_and_ranges_parse_and_bad_ones_are_refused() {
        assert_eq!(
            nm(&parse_list("450nm,0.55um,650").unwrap()),
            [450.0, 550.0, 650.0]
        );
        assert_eq!(
            nm(&parse_range("400nm:700nm:4").unwrap()),
            [400.0, 500.0, 600.0, 700.0]
        );
        assert_eq!(parse_range("400nm:700nm:31").unwrap().len(), 31);
        for bad in ["450nm,,550nm", "450nm,900nm", "450nm,450nm", "blue"] {
            assert!(parse_list(bad).is_err(), "{bad}");
        }
        for bad in [
            "400nm:700nm",
            "700nm:400nm:3",
            "400nm:700nm:1",
            "400nm:700nm:x",
        ] {
            assert!(parse_range(bad).is_err(), "{bad}");
        }
    }

    /// The trapezoid weights by hand: 450, 550, 650 nm have intervals 50, 100, 50 nm.
    #[test]
    fn luminance_weights_are_the_trapezoid_rule() {
        let list = parse_list("650nm,450nm,550nm").unwrap();
        let y = |n: f64| Wavelength::from_nm(n).unwrap().ybar();
        let raw = [y(650.0) * 50.0, y(450.0) * 50.0, y(550.0) * 100.0];
        let sum: f64 = raw.iter().sum();
        let w = luminance_weights(&list);
        for (a, b) in w.iter().zip(raw) {
            assert!((a - b / sum).abs() < 1e-12, "{w:?}");
        }
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        assert_eq!(luminance_weights(&list[..1]), [1.0]);
    }
}
