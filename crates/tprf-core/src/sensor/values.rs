//! Serde helpers for sensor files: times as seconds or strings with a unit, frequencies
//! as hertz or strings with a unit, counts, and `[t_s, value]` points.

use serde::de::{self, Deserializer, Visitor};
use serde::{Deserialize, Serialize, Serializer};
use std::fmt;

use crate::units::parse_time_s;

/// A time field: a number is seconds; a string carries its unit (`"2 ns"`, `"150ps"`,
/// or an optical path length `"30 cm"`, converted with `t = opl / c`). Written back
/// as seconds.
pub mod seconds {
    use super::*;

    pub fn serialize<S: Serializer>(value: &f64, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_f64(*value)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        d.deserialize_any(UnitVisitor {
            expecting: "seconds: a number, or a string with a unit such as \"2 ns\" or \"30 cm\"",
            parse: parse_time_s,
        })
    }
}

/// A frequency field: a number is hertz; a string carries its unit (`"20 MHz"`).
pub mod hertz {
    use super::*;

    pub fn serialize<S: Serializer>(value: &f64, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_f64(*value)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        d.deserialize_any(UnitVisitor {
            expecting: "hertz: a number, or a string with a unit such as \"20 MHz\"",
            parse: parse_frequency_hz,
        })
    }
}

/// A count: a non-negative integer (an integral float such as `1e3` is accepted too).
pub mod count {
    use super::*;

    pub fn serialize<S: Serializer>(value: &u64, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u64(*value)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<u64, D::Error> {
        struct CountVisitor;
        impl Visitor<'_> for CountVisitor {
            type Value = u64;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a non-negative whole number")
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<u64, E> {
                Ok(v)
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<u64, E> {
                u64::try_from(v).map_err(|_| E::custom(format!("{v} is negative")))
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<u64, E> {
                if v.is_finite() && v >= 0.0 && v.fract() == 0.0 && v < 1.8e19 {
                    Ok(v as u64)
                } else {
                    Err(E::custom(format!("{v} is not a non-negative whole number")))
                }
            }
        }
        d.deserialize_any(CountVisitor)
    }
}

struct UnitVisitor {
    expecting: &'static str,
    parse: fn(&str) -> Result<f64, String>,
}

impl Visitor<'_> for UnitVisitor {
    type Value = f64;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.expecting)
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<f64, E> {
        Ok(v)
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<f64, E> {
        Ok(v as f64)
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<f64, E> {
        Ok(v as f64)
    }
    fn visit_str<E: de::Error>(self, v: &str) -> Result<f64, E> {
        (self.parse)(v).map_err(E::custom)
    }
}

/// `"20 MHz"`, `"1.5GHz"`, `"500 kHz"`, `"10 Hz"` -> hertz.
pub fn parse_frequency_hz(text: &str) -> Result<f64, String> {
    let t = text.trim();
    let split = t
        .find(|ch: char| ch.is_ascii_alphabetic())
        .ok_or_else(|| format!("'{text}' has no unit (use Hz kHz MHz GHz)"))?;
    let (num, unit) = t.split_at(split);
    let value: f64 = num
        .trim()
        .parse()
        .map_err(|_| format!("'{text}': '{}' is not a number", num.trim()))?;
    let scale = match unit.trim() {
        "Hz" | "hz" => 1.0,
        "kHz" | "khz" => 1e3,
        "MHz" | "mhz" => 1e6,
        "GHz" | "ghz" => 1e9,
        other => {
            return Err(format!(
                "'{text}': unknown unit '{other}' (use Hz kHz MHz GHz)"
            ));
        }
    };
    Ok(value * scale)
}

/// One knot of a piecewise-linear envelope: `[t_s, value]`, the time in seconds or a
/// string with a unit (`"2 ns"`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Point(#[serde(with = "seconds")] pub f64, pub f64);

/// An optional time field, as [`seconds`] when present.
pub mod option_seconds {
    use super::*;

    pub fn serialize<S: Serializer>(value: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
        match value {
            Some(v) => s.serialize_some(v),
            None => s.serialize_none(),
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
        seconds::deserialize(d).map(Some)
    }
}
