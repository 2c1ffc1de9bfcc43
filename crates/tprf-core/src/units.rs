//! Physical constants and unit parsing for the time axis.

/// Speed of light in vacuum, m/s (exact, SI).
pub const C_M_PER_S: f64 = 299_792_458.0;

/// A quantity on the time axis given with a unit: `2ns`, `150ps`, `3.5m`, `10 cm`,
/// `3.5e-9s`, `1e6 s`.
/// Time units `s ms us ns ps fs`; optical-path-length units `m cm mm km`, converted to
/// time with `t = opl / c`. Returns seconds.
pub fn parse_time_s(text: &str) -> Result<f64, String> {
    let t = text.trim();
    // The unit is the trailing run of letters, so that `3.5e-9s` and `1e6 s` parse.
    let is_unit = |ch: char| ch.is_ascii_alphabetic() || ch == 'µ';
    let split = t
        .char_indices()
        .rev()
        .take_while(|&(_, ch)| is_unit(ch))
        .last()
        .map(|(i, _)| i)
        .ok_or_else(|| format!("'{text}' has no unit (use s ms us ns ps fs, or m cm mm km)"))?;
    let (num, unit) = t.split_at(split);
    let value: f64 = num
        .trim()
        .parse()
        .map_err(|_| format!("'{text}': '{}' is not a number", num.trim()))?;
    if !value.is_finite() {
        return Err(format!("'{text}' is not finite"));
    }
    let seconds = match unit.trim() {
        "s" => value,
        "ms" => value * 1e-3,
        "us" | "µs" => value * 1e-6,
        "ns" => value * 1e-9,
        "ps" => value * 1e-12,
        "fs" => value * 1e-15,
        "m" => value / C_M_PER_S,
        "cm" => value * 1e-2 / C_M_PER_S,
        "mm" => value * 1e-3 / C_M_PER_S,
        "km" => value * 1e3 / C_M_PER_S,
        other => {
            return Err(format!(
                "'{text}': unknown unit '{other}' (use s ms us ns ps fs, or m cm mm km)"
            ));
        }
    };
    // `1e308 km` is finite as written but not in seconds.
    if !seconds.is_finite() {
        return Err(format!("'{text}' is too large to be a time in seconds"));
    }
    Ok(seconds)
}

/// The unit a time reads best in: fs/ps/ns/us/ms/s so the number is in [1, 1000) (0
/// and anything over a second in s), with the factor from seconds to it.
pub fn time_unit(seconds: f64) -> (f64, &'static str) {
    let a = seconds.abs();
    if a == 0.0 || a >= 1.0 {
        (1.0, "s")
    } else if a >= 1e-3 {
        (1e3, "ms")
    } else if a >= 1e-6 {
        (1e6, "us")
    } else if a >= 1e-9 {
        (1e9, "ns")
    } else if a >= 1e-12 {
        (1e12, "ps")
    } else {
        (1e15, "fs")
    }
}

/// A readable time: picks fs/ps/ns/us/ms/s so the number is in [1, 1000); zero is
/// `0 ns` (beside the nanoseconds a transient's times are read in, not `0.0000 s`).
pub fn format_time(seconds: f64) -> String {
    if seconds == 0.0 {
        return "0 ns".into();
    }
    let (scale, unit) = time_unit(seconds);
    format!("{:.4} {unit}", seconds * scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_convert() {
        assert_eq!(parse_time_s("2ns").unwrap(), 2e-9);
        assert_eq!(parse_time_s(" 150 ps").unwrap(), 150e-12);
        assert!((parse_time_s("1m").unwrap() - 1.0 / 299_792_458.0).abs() < 1e-20);
        assert!((parse_time_s("1km").unwrap() * C_M_PER_S - 1000.0).abs() < 1e-9);
        assert!(parse_time_s("3").is_err());
        assert!(parse_time_s("3 furlongs").is_err());
        assert!(parse_time_s("nanns").is_err());
        assert_eq!(parse_time_s("3.5e-9s").unwrap(), 3.5e-9);
        assert_eq!(parse_time_s("1e6 s").unwrap(), 1e6);
        assert!((parse_time_s("2E-3m").unwrap() * C_M_PER_S - 2e-3).abs() < 1e-15);
        assert!(parse_time_s("1e9").is_err());
        assert!(parse_time_s("inf s").is_err());
    }

    #[test]
    fn times_format_in_their_unit() {
        assert_eq!(format_time(0.0), "0 ns");
        assert_eq!(format_time(640e-9), "640.0000 ns");
        assert_eq!(format_time(1.25e-12), "1.2500 ps");
        assert_eq!(format_time(2.0), "2.0000 s");
    }
}
