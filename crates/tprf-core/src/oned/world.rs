//! The 1-D world file (`docs/oned.md`): directions, interfaces and their sides, the
//! refractive index of each segment, and the validation that turns a [`WorldFile`] into
//! a [`World`] (or a [`WorldError`] that says what is wrong).

use std::collections::BTreeSet;
use std::fmt;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// A direction on the line: travel, looking or emission.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Direction {
    /// Towards decreasing `x` (-1).
    Left,
    /// Towards increasing `x` (+1).
    Right,
}

impl Direction {
    /// -1 for left, +1 for right.
    pub fn sign(self) -> f64 {
        match self {
            Direction::Left => -1.0,
            Direction::Right => 1.0,
        }
    }

    /// The other direction.
    pub fn opposite(self) -> Self {
        match self {
            Direction::Left => Direction::Right,
            Direction::Right => Direction::Left,
        }
    }

    /// `"left"` or `"right"`, as in the file format.
    pub fn name(self) -> &'static str {
        match self {
            Direction::Left => "left",
            Direction::Right => "right",
        }
    }
}

impl fmt::Display for Direction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl Serialize for Direction {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.name())
    }
}

/// Accepts `"left"`, `"right"`, `-1` and `1` (`+1` = right).
impl<'de> Deserialize<'de> for Direction {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct DirectionVisitor;
        impl serde::de::Visitor<'_> for DirectionVisitor {
            type Value = Direction;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a direction: \"left\", \"right\", -1 (left) or 1 (right)")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Direction, E> {
                match v {
                    "left" => Ok(Direction::Left),
                    "right" => Ok(Direction::Right),
                    other => Err(E::invalid_value(serde::de::Unexpected::Str(other), &self)),
                }
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Direction, E> {
                match v {
                    -1 => Ok(Direction::Left),
                    1 => Ok(Direction::Right),
                    other => Err(E::invalid_value(
                        serde::de::Unexpected::Signed(other),
                        &self,
                    )),
                }
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Direction, E> {
                match v {
                    1 => Ok(Direction::Right),
                    other => Err(E::invalid_value(
                        serde::de::Unexpected::Unsigned(other),
                        &self,
                    )),
                }
            }
        }
        deserializer.deserialize_any(DirectionVisitor)
    }
}

/// The three interface kinds of the paper's section 4.3.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum InterfaceKind {
    /// A physical surface with the reflectance and transmittance of its two sides.
    #[default]
    Real,
    /// Transparent, `K = delta(w - w')`: transmittance 1, reflectance 0, both sides.
    /// Useful to change the refractive index without scattering.
    Virtual,
    /// Absorbing, `K = 0`: the world ends here.
    Boundary,
}

impl fmt::Display for InterfaceKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            InterfaceKind::Real => "real",
            InterfaceKind::Virtual => "virtual",
            InterfaceKind::Boundary => "boundary",
        })
    }
}

/// What one side of an interface does to the light that hits it (dimensionless
/// fractions of the incident flux). The rest, `1 - reflectance - transmittance`, is
/// absorbed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Side {
    /// Fraction sent back towards the side it came from. Default 0.
    #[serde(default)]
    pub reflectance: f64,
    /// Fraction passed through, direction unchanged. Default 0.
    #[serde(default)]
    pub transmittance: f64,
}

/// One interface as written in a file (not yet validated).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InterfaceSpec {
    /// Label used in messages and output. Default `"#i"`, `i` the index in the file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Position on the line, metres.
    pub x_m: f64,
    /// Default [`InterfaceKind::Real`].
    #[serde(default)]
    pub kind: InterfaceKind,
    /// The side facing decreasing `x`: acts on light arriving from the left (travelling
    /// right). Missing: opaque and black (reflectance 0, transmittance 0). Only for
    /// `real` interfaces.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub left: Option<Side>,
    /// The side facing increasing `x`: acts on light arriving from the right (travelling
    /// left). Missing: opaque and black. Only for `real` interfaces.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub right: Option<Side>,
}

/// A 1-D world as written in a JSON file (not yet validated); see `docs/oned.md`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorldFile {
    /// The interfaces, in any order (they are sorted by `x_m`). Default none.
    #[serde(default)]
    pub interfaces: Vec<InterfaceSpec>,
    /// Eye point E, metres. Must not lie on an interface.
    pub eye_m: f64,
    /// The side the eye looks to; it sees the light arriving from that side.
    pub look: Direction,
    /// Light point L, metres. Must not lie on an interface.
    pub light_m: f64,
    /// Refractive index of each segment, left to right **by position**: entry 0 is left
    /// of the leftmost interface, entry `i` between the `i`-th and `(i+1)`-th interface
    /// from the left, the last right of the rightmost one; `interfaces.len() + 1`
    /// entries, each >= 1. Default: 1 everywhere.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub segment_ior: Option<Vec<f64>>,
}

/// A validated interface: its sides are explicit whatever its kind.
#[derive(Clone, Debug, PartialEq)]
pub struct Interface {
    pub name: String,
    /// Position, metres.
    pub x_m: f64,
    pub kind: InterfaceKind,
    /// Acts on light travelling right (arriving from the left).
    pub left: Side,
    /// Acts on light travelling left (arriving from the right).
    pub right: Side,
}

/// Why a 1-D world cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum WorldError {
    // The causes are in the messages, not chained as `source()`, so that `{:#}`
    // (anyhow's chain) does not print them twice.
    #[error("cannot read 1-D world file {path}: {error}")]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("not a valid 1-D world file: {0}")]
    Json(serde_json::Error),
    #[error("{what} is {value}, which is not a finite number")]
    NotFinite { what: String, value: f64 },
    #[error("interface '{name}', {side} side: {quantity} {value} is outside [0, 1]")]
    OutOfRange {
        name: String,
        side: Direction,
        quantity: &'static str,
        value: f64,
    },
    #[error(
        "interface '{name}', {side} side: reflectance {reflectance} + transmittance \
         {transmittance} exceeds 1 (the interface would create energy)"
    )]
    EnergyGain {
        name: String,
        side: Direction,
        reflectance: f64,
        transmittance: f64,
    },
    #[error(
        "interface '{name}' is a {kind} interface, whose scattering is fixed: \
         remove its '{side}' side"
    )]
    SideOnFixedKind {
        name: String,
        kind: InterfaceKind,
        side: Direction,
    },
    #[error("two interfaces are named '{name}'; names must be unique")]
    DuplicateName { name: String },
    #[error("interfaces '{first}' and '{second}' are both at x = {x_m} m; positions must differ")]
    DuplicatePosition {
        first: String,
        second: String,
        x_m: f64,
    },
    #[error(
        "segment_ior has {got} entries, but {interfaces} interfaces make {expected} segments \
         (one left of the leftmost interface, one between each neighbouring pair, one right \
         of the rightmost)"
    )]
    IorCount {
        got: usize,
        expected: usize,
        interfaces: usize,
    },
    #[error("segment_ior[{index}] = {value}: a refractive index must be >= 1")]
    IorBelowOne { index: usize, value: f64 },
    #[error("the {what} at x = {x_m} m lies on interface '{name}'; move it into a segment")]
    OnInterface {
        what: &'static str,
        x_m: f64,
        name: String,
    },
    #[error(
        "boundary interface '{name}' at x = {x_m} m lies between the eye ({eye_m} m) and the \
         light ({light_m} m): no light can reach the eye"
    )]
    Separated {
        name: String,
        x_m: f64,
        eye_m: f64,
        light_m: f64,
    },
    #[error("cannot scale a world by {scale}: the factor must be positive and finite")]
    BadScale { scale: f64 },
    #[error(
        "{culprit}: the world's optical extent (the sum of n d from the leftmost to the \
         rightmost of the eye, the light and the interfaces) would be {extent_m:e} m, and \
         arrival times would overflow; it must stay below {max_m:e} m (so that a path of \
         up to 2^32 reflections arrives at a finite time): use a smaller index or distance"
    )]
    TimeOverflow {
        culprit: String,
        extent_m: f64,
        max_m: f64,
    },
}

/// The longest optical extent a world may have, metres: the sum of `n d` over the
/// stretch from the leftmost to the rightmost of the eye, the light and the interfaces.
/// Every straight run of light between two events lies inside that stretch, and a path
/// with `k` reflections has `k + 1` runs, so its optical path length is at most
/// `(k + 1)` times the extent. At 1e288 m a path of 2^32 reflections (more than
/// [`super::ImpulseOptions::max_order`] can ask for) is shorter than 4.3e297 m and
/// arrives in under 1.5e298 ns: finite in seconds and in the nanoseconds `tprf oned`
/// prints, with ten orders of magnitude to spare for the sums.
pub const MAX_OPTICAL_EXTENT_M: f64 = 1e288;

/// Slack on `reflectance + transmittance <= 1` for decimal inputs such as 0.6 + 0.4.
const ENERGY_SLACK: f64 = 1e-12;

/// A validated 1-D world: interfaces sorted by position, one refractive index per
/// segment. Build it with [`World::new`], [`World::from_json_str`] or
/// [`World::from_path`]; it also deserialises directly (validating).
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(try_from = "WorldFile", into = "WorldFile")]
pub struct World {
    interfaces: Vec<Interface>,
    eye_m: f64,
    look: Direction,
    light_m: f64,
    segment_ior: Vec<f64>,
}

impl TryFrom<WorldFile> for World {
    type Error = WorldError;
    fn try_from(file: WorldFile) -> Result<Self, WorldError> {
        World::new(file)
    }
}

impl From<World> for WorldFile {
    fn from(world: World) -> Self {
        WorldFile {
            interfaces: world
                .interfaces
                .into_iter()
                .map(|i| {
                    let real = i.kind == InterfaceKind::Real;
                    InterfaceSpec {
                        name: Some(i.name),
                        x_m: i.x_m,
                        kind: i.kind,
                        left: real.then_some(i.left),
                        right: real.then_some(i.right),
                    }
                })
                .collect(),
            eye_m: world.eye_m,
            look: world.look,
            light_m: world.light_m,
            segment_ior: Some(world.segment_ior),
        }
    }
}

/// `x` in messages: as written for everyday magnitudes, in exponent form otherwise
/// (`1e300`, not three hundred digits).
fn short(x: f64) -> String {
    if x == 0.0 || (1e-4..1e15).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

fn check_finite(what: impl FnOnce() -> String, value: f64) -> Result<(), WorldError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(WorldError::NotFinite {
            what: what(),
            value,
        })
    }
}

fn check_side(name: &str, side: Direction, s: &Side) -> Result<(), WorldError> {
    for (quantity, value) in [
        ("reflectance", s.reflectance),
        ("transmittance", s.transmittance),
    ] {
        check_finite(
            || format!("interface '{name}', {side} side, {quantity}"),
            value,
        )?;
        if !(0.0..=1.0).contains(&value) {
            return Err(WorldError::OutOfRange {
                name: name.to_string(),
                side,
                quantity,
                value,
            });
        }
    }
    if s.reflectance + s.transmittance > 1.0 + ENERGY_SLACK {
        return Err(WorldError::EnergyGain {
            name: name.to_string(),
            side,
            reflectance: s.reflectance,
            transmittance: s.transmittance,
        });
    }
    Ok(())
}

impl World {
    /// Validates a parsed file: finite numbers; `0 <= r, t` and `r + t <= 1` on every
    /// side; unique names; distinct positions (the interfaces are sorted by `x_m`);
    /// `segment_ior` of the right length with every entry >= 1; E and L not on an
    /// interface; no boundary between E and L.
    pub fn new(file: WorldFile) -> Result<Self, WorldError> {
        check_finite(|| "eye_m".to_string(), file.eye_m)?;
        check_finite(|| "light_m".to_string(), file.light_m)?;

        let mut names = BTreeSet::new();
        let mut interfaces = Vec::with_capacity(file.interfaces.len());
        for (index, spec) in file.interfaces.into_iter().enumerate() {
            let name = spec.name.unwrap_or_else(|| format!("#{index}"));
            check_finite(|| format!("interface '{name}', x_m"), spec.x_m)?;
            if !names.insert(name.clone()) {
                return Err(WorldError::DuplicateName { name });
            }
            let (left, right) = match spec.kind {
                InterfaceKind::Real => {
                    let left = spec.left.unwrap_or_default();
                    let right = spec.right.unwrap_or_default();
                    check_side(&name, Direction::Left, &left)?;
                    check_side(&name, Direction::Right, &right)?;
                    (left, right)
                }
                kind => {
                    for (side, given) in [
                        (Direction::Left, spec.left.is_some()),
                        (Direction::Right, spec.right.is_some()),
                    ] {
                        if given {
                            return Err(WorldError::SideOnFixedKind { name, kind, side });
                        }
                    }
                    let t = if kind == InterfaceKind::Virtual {
                        1.0
                    } else {
                        0.0
                    };
                    let s = Side {
                        reflectance: 0.0,
                        transmittance: t,
                    };
                    (s, s)
                }
            };
            interfaces.push(Interface {
                name,
                x_m: spec.x_m,
                kind: spec.kind,
                left,
                right,
            });
        }
        interfaces.sort_by(|a, b| a.x_m.total_cmp(&b.x_m));
        for pair in interfaces.windows(2) {
            if let [a, b] = pair
                && a.x_m == b.x_m
            {
                return Err(WorldError::DuplicatePosition {
                    first: a.name.clone(),
                    second: b.name.clone(),
                    x_m: a.x_m,
                });
            }
        }

        let expected = interfaces.len() + 1;
        let segment_ior = match file.segment_ior {
            None => vec![1.0; expected],
            Some(ior) => {
                if ior.len() != expected {
                    return Err(WorldError::IorCount {
                        got: ior.len(),
                        expected,
                        interfaces: interfaces.len(),
                    });
                }
                for (index, &value) in ior.iter().enumerate() {
                    check_finite(|| format!("segment_ior[{index}]"), value)?;
                    if value < 1.0 {
                        return Err(WorldError::IorBelowOne { index, value });
                    }
                }
                ior
            }
        };

        for (what, x_m) in [("eye", file.eye_m), ("light", file.light_m)] {
            if let Some(i) = interfaces.iter().find(|i| i.x_m == x_m) {
                return Err(WorldError::OnInterface {
                    what,
                    x_m,
                    name: i.name.clone(),
                });
            }
        }
        let (lo, hi) = if file.eye_m <= file.light_m {
            (file.eye_m, file.light_m)
        } else {
            (file.light_m, file.eye_m)
        };
        if let Some(b) = interfaces
            .iter()
            .find(|i| i.kind == InterfaceKind::Boundary && lo < i.x_m && i.x_m < hi)
        {
            return Err(WorldError::Separated {
                name: b.name.clone(),
                x_m: b.x_m,
                eye_m: file.eye_m,
                light_m: file.light_m,
            });
        }

        let world = World {
            interfaces,
            eye_m: file.eye_m,
            look: file.look,
            light_m: file.light_m,
            segment_ior,
        };
        world.check_optical_extent()?;
        Ok(world)
    }

    /// Refuse a world whose times could overflow: its optical extent (see
    /// [`MAX_OPTICAL_EXTENT_M`]) summed piece by piece between consecutive points (the
    /// interfaces, the eye and the light, sorted), each piece `n (x_b - x_a)` metres with
    /// `n` the index of the segment it lies in. The error names the field to blame: two
    /// positions too far apart, or the index that makes a piece too long in time.
    fn check_optical_extent(&self) -> Result<(), WorldError> {
        let mut points: Vec<(f64, String)> = self
            .interfaces
            .iter()
            .map(|i| {
                (
                    i.x_m,
                    format!("interface '{}' (x_m = {})", i.name, short(i.x_m)),
                )
            })
            .collect();
        points.push((
            self.eye_m,
            format!("the eye (eye_m = {})", short(self.eye_m)),
        ));
        points.push((
            self.light_m,
            format!("the light (light_m = {})", short(self.light_m)),
        ));
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Consecutive points in one segment make one stretch: (segment, from, to).
        let mut stretches: Vec<(usize, usize, usize)> = Vec::new();
        for (k, pair) in points.windows(2).enumerate() {
            let [(xa, _), (xb, _)] = pair else { continue };
            if xa == xb {
                continue; // the eye and the light at one point
            }
            // The segment holding the open interval (xa, xb): interfaces at or left of xa.
            let segment = self.interfaces.partition_point(|i| i.x_m <= *xa);
            match stretches.last_mut() {
                Some((s, _, to)) if *s == segment => *to = k + 1,
                _ => stretches.push((segment, k, k + 1)),
            }
        }
        let mut extent_m = 0.0;
        // The stretch with the longest optical length, and what to blame for it.
        let mut worst: Option<(f64, String)> = None;
        for (segment, from, to) in stretches {
            let (Some((xa, a)), Some((xb, b))) = (points.get(from), points.get(to)) else {
                continue;
            };
            let length_m = xb - xa;
            let ior = self.segment_ior.get(segment).copied().unwrap_or(1.0);
            let opl_m = ior * length_m;
            extent_m += opl_m;
            let culprit = if !(length_m <= MAX_OPTICAL_EXTENT_M) || ior == 1.0 {
                format!("{a} and {b} are {length_m:e} m apart")
            } else {
                format!(
                    "segment_ior[{segment}] = {ior:e} over the {} m from {a} to {b} \
                     makes {opl_m:e} m of optical path",
                    short(length_m)
                )
            };
            if worst.as_ref().is_none_or(|(w, _)| !(opl_m <= *w)) {
                worst = Some((opl_m, culprit));
            }
        }
        match worst {
            Some((_, culprit)) if !(extent_m <= MAX_OPTICAL_EXTENT_M) => {
                Err(WorldError::TimeOverflow {
                    culprit,
                    extent_m,
                    max_m: MAX_OPTICAL_EXTENT_M,
                })
            }
            _ => Ok(()),
        }
    }

    /// Parses and validates a world from JSON text.
    pub fn from_json_str(text: &str) -> Result<Self, WorldError> {
        let file: WorldFile = serde_json::from_str(text).map_err(WorldError::Json)?;
        World::new(file)
    }

    /// Reads, parses and validates a world file.
    pub fn from_path(path: &Path) -> Result<Self, WorldError> {
        let text =
            crate::budget::read_text(path, "the 1-D world file").map_err(|m| WorldError::Io {
                path: path.to_path_buf(),
                error: std::io::Error::other(m),
            })?;
        World::from_json_str(&text)
    }

    /// The interfaces, sorted by position.
    pub fn interfaces(&self) -> &[Interface] {
        &self.interfaces
    }

    /// Eye point E, metres.
    pub fn eye_m(&self) -> f64 {
        self.eye_m
    }

    /// The side E looks to.
    pub fn look(&self) -> Direction {
        self.look
    }

    /// Light point L, metres.
    pub fn light_m(&self) -> f64 {
        self.light_m
    }

    /// Refractive index per segment, left to right (`interfaces().len() + 1` entries).
    pub fn segment_ior(&self) -> &[f64] {
        &self.segment_ior
    }

    /// The same world with every position multiplied by `scale` (> 0): its TPRF has the
    /// same weights at times multiplied by `scale`.
    pub fn scaled(&self, scale: f64) -> Result<Self, WorldError> {
        if !(scale.is_finite() && scale > 0.0) {
            return Err(WorldError::BadScale { scale });
        }
        let mut file = WorldFile::from(self.clone());
        file.eye_m *= scale;
        file.light_m *= scale;
        for i in &mut file.interfaces {
            i.x_m *= scale;
        }
        World::new(file)
    }

    /// Index of the segment holding `x_m` (not on an interface): the number of
    /// interfaces left of it.
    pub(super) fn segment_of(&self, x_m: f64) -> usize {
        self.interfaces.partition_point(|i| i.x_m < x_m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A world of interfaces A at 10 m and B at 25 m, the eye at 0 and the light at -0.5,
    /// with `segment_ior` and B moved to `b_m`.
    fn world(segment_ior: [f64; 3], b_m: f64) -> Result<World, WorldError> {
        World::from_json_str(&format!(
            r#"{{"interfaces": [
                {{"name": "A", "x_m": 10.0, "left": {{"reflectance": 0.3, "transmittance": 0.6}}}},
                {{"name": "B", "x_m": {b_m:e}, "left": {{"reflectance": 0.8}}}}],
              "eye_m": 0.0, "look": "right", "light_m": -0.5,
              "segment_ior": [{}, {}, {}]}}"#,
            segment_ior[0], segment_ior[1], segment_ior[2]
        ))
    }

    fn overflow(r: Result<World, WorldError>) -> String {
        match r {
            Err(e @ WorldError::TimeOverflow { .. }) => e.to_string(),
            Err(e) => format!("another error: {e}"),
            Ok(_) => "accepted".into(),
        }
    }

    #[test]
    fn what_makes_times_overflow_is_refused_by_name() {
        // The issue's case: an index of 1e308 made every time infinite.
        let e = overflow(world([1.0, 1e308, 1.0], 25.0));
        assert!(
            e.contains(
                "segment_ior[1] = 1e308 over the 15 m from interface 'A' (x_m = 10) \
                 to interface 'B' (x_m = 25) makes inf m"
            ),
            "{e}"
        );
        // Finite, but a path of many reflections would not be.
        let e = overflow(world([1.0, 1e290, 1.0], 25.0));
        assert!(e.contains("segment_ior[1] = 1e290"), "{e}");
        // The eye and the light's segment counts (the first leg), by its index...
        let e = overflow(world([1e300, 1.0, 1.0], 25.0));
        assert!(
            e.contains(
                "segment_ior[0] = 1e300 over the 10.5 m from the light (light_m = -0.5) \
                 to interface 'A'"
            ),
            "{e}"
        );
        // ...and positions too far apart, whatever the index.
        let e = overflow(world([1.0, 1.0, 1.0], 1e300));
        assert!(
            e.contains(
                "interface 'A' (x_m = 10) and interface 'B' (x_m = 1e300) are 1e300 m apart"
            ),
            "{e}"
        );
        // Nothing crosses the segment right of B, so its index scales no time.
        assert!(world([1.0, 1.0, 1e308], 25.0).is_ok());
        // Large but safe: 1e280 m of extent.
        assert!(world([1.0, 1e279, 1.0], 25.0).is_ok());
        // A scale that pushes the world past the limit is refused the same way.
        let Ok(w) = world([1.0, 1e279, 1.0], 25.0) else {
            panic!("valid world");
        };
        assert!(overflow(w.scaled(1e10)).contains("segment_ior[1]"));
    }

    #[test]
    fn direction_parses_names_and_signs() {
        let parse = |s: &str| serde_json::from_str::<Direction>(s);
        assert_eq!(parse("\"left\"").ok(), Some(Direction::Left));
        assert_eq!(parse("\"right\"").ok(), Some(Direction::Right));
        assert_eq!(parse("-1").ok(), Some(Direction::Left));
        assert_eq!(parse("1").ok(), Some(Direction::Right));
        assert!(parse("0").is_err());
        assert!(parse("\"up\"").is_err());
        assert!(parse("2").is_err());
    }
}
