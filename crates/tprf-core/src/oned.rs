//! The paper's 1-D world (Smith, Skorupski & Davis 2008, section 5 and Figure 4),
//! solved exactly.
//!
//! A line carries *interfaces* (points) with a reflectance and a transmittance on each
//! side, an eye point E looking left or right, and a light point L that emits a unit
//! delta pulse at `t = 0` in both directions (weight 1 each way). Each segment between
//! consecutive interfaces has its own refractive index `n`, so light crosses a segment
//! of length `d` in `D = n d / c` seconds.
//!
//! In one dimension every term of the Neumann series `R = R0 + G R0 + G G R0 + ...`
//! (section 4.1) is a finite sum of delayed, weighted deltas, so the TPRF of section 5,
//! `TPRF(t) = I*(E, w, t)`, is an exact train of weighted impulses. [`World::impulses`]
//! enumerates it; [`binned`] integrates it over time bins.
//!
//! Conventions:
//! - The eye looking right sees the light that arrives at E *from the right*, i.e.
//!   travels leftwards through E; looking left, the light travelling rightwards. The
//!   eye is transparent: light passes through E and goes on.
//! - An impulse's `order` counts the **reflections** along its path. Transmission
//!   through an interface keeps the direction (the paper's virtual pass-through,
//!   `K = delta(w - w')`) and is not counted, even at a real, partly transparent
//!   interface. Light going straight from L to E is order 0; it is seen only when L
//!   lies strictly on the side E looks to (with L = E the pulse leaves E and is not
//!   seen).
//! - Light that leaves the outermost interface outwards meets nothing and never comes
//!   back (it *escapes*); a *boundary* interface absorbs everything that reaches it,
//!   from either side.
//! - The file format is documented in `docs/oned.md`.

use std::collections::BTreeMap;
use std::collections::BTreeSet;
use std::fmt;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::units::C_M_PER_S;

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
}

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

        Ok(World {
            interfaces,
            eye_m: file.eye_m,
            look: file.look,
            light_m: file.light_m,
            segment_ior,
        })
    }

    /// Parses and validates a world from JSON text.
    pub fn from_json_str(text: &str) -> Result<Self, WorldError> {
        let file: WorldFile = serde_json::from_str(text).map_err(WorldError::Json)?;
        World::new(file)
    }

    /// Reads, parses and validates a world file.
    pub fn from_path(path: &Path) -> Result<Self, WorldError> {
        let text = std::fs::read_to_string(path).map_err(|error| WorldError::Io {
            path: path.to_path_buf(),
            error,
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

    /// The exact TPRF at E looking [`World::look`] (section 5:
    /// `TPRF(t) = I*(E, w, t)`) for a unit delta pulse leaving L at `t = 0` each way,
    /// as impulses sorted by time (seconds); see [`World::impulse_train`].
    pub fn impulses(&self, opts: &ImpulseOptions) -> Vec<Impulse> {
        self.impulse_train(opts).impulses
    }

    /// The exact TPRF with the fate of the emitted energy.
    ///
    /// Evaluates the Neumann series `R = R0 + G R0 + G G R0 + ...` (section 4.1)
    /// generation by generation, generation `k` holding the light reflected `k` times:
    /// each packet travels straight on, each interface it meets sends the fraction `r`
    /// of it into generation `k + 1` and passes the fraction `t` on; every crossing of a
    /// segment of length `d` and index `n` delays it by `D = n d / c` (seconds). Packets
    /// that reach the same interface in the same direction over the same segments
    /// (hence at exactly the same time) are merged, which keeps the work polynomial in
    /// the order. An impulse is recorded each time light passes E travelling away from
    /// the side E looks to (arriving from that side).
    ///
    /// Cuts (their energy is reported in [`EnergyBudget`]): a packet whose weight falls
    /// below `min_weight`, whose time exceeds `t_max_s`, or whose order would exceed
    /// `max_order`. Impulses of the same order whose times agree to `merge_rel`
    /// (relative) are merged.
    pub fn impulse_train(&self, opts: &ImpulseOptions) -> ImpulseTrain {
        let mut engine = Engine::new(self, opts);
        engine.run();
        ImpulseTrain {
            impulses: merge_impulses(engine.impulses, opts.merge_rel),
            energy: engine.energy,
            truncated: engine.truncated,
        }
    }

    /// Index of the segment holding `x_m` (not on an interface): the number of
    /// interfaces left of it.
    fn segment_of(&self, x_m: f64) -> usize {
        self.interfaces.partition_point(|i| i.x_m < x_m)
    }
}

/// Cut-offs and tolerances of [`World::impulses`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImpulseOptions {
    /// Packets lighter than this (fraction of a unit pulse) are dropped. Default 1e-12.
    pub min_weight: f64,
    /// Light later than this (seconds) is dropped. Default infinity.
    pub t_max_s: f64,
    /// Paths with more reflections are dropped. Default 1000.
    pub max_order: u32,
    /// Impulses of equal order whose times differ by at most this fraction of the
    /// time are merged into one. Default 1e-15.
    pub merge_rel: f64,
    /// Safety limit on distinct live packets per order (memory); beyond it the
    /// enumeration drops packets and reports `truncated`. Default 500_000.
    pub max_packets: usize,
}

impl Default for ImpulseOptions {
    fn default() -> Self {
        ImpulseOptions {
            min_weight: 1e-12,
            t_max_s: f64::INFINITY,
            max_order: 1000,
            merge_rel: 1e-15,
            max_packets: 500_000,
        }
    }
}

/// One weighted delta of the TPRF: `weight * delta(t - time_s)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Impulse {
    /// Arrival time at E, seconds after the pulse left L.
    pub time_s: f64,
    /// Flux, as a fraction of the unit pulse emitted in one direction.
    pub weight: f64,
    /// Number of reflections along the path (transmissions do not count).
    pub order: u32,
}

impl Impulse {
    /// Optical path length L -> E, metres: `c * time_s` (the sum of `n d` over the
    /// path).
    pub fn opl_m(&self) -> f64 {
        self.time_s * C_M_PER_S
    }
}

/// Where the emitted energy went (fractions of a unit pulse; two are emitted).
/// `emitted = escaped + absorbed + cut_total()` up to rounding. The eye is
/// transparent, so the light it sees is not a separate term.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EnergyBudget {
    /// 2: one unit each way.
    pub emitted: f64,
    /// Left the world past the outermost interface.
    pub escaped: f64,
    /// Absorbed by boundary interfaces and by real ones (`1 - r - t`).
    pub absorbed: f64,
    /// Dropped below `min_weight`.
    pub cut_weight: f64,
    /// Dropped after `t_max_s`.
    pub cut_time: f64,
    /// Dropped beyond `max_order`.
    pub cut_order: f64,
    /// Dropped by the `max_packets` limit.
    pub cut_packets: f64,
}

impl EnergyBudget {
    /// All the energy dropped by cut-offs.
    pub fn cut_total(&self) -> f64 {
        self.cut_weight + self.cut_time + self.cut_order + self.cut_packets
    }

    /// `emitted - escaped - absorbed - cut_total()`: zero up to rounding.
    pub fn imbalance(&self) -> f64 {
        self.emitted - self.escaped - self.absorbed - self.cut_total()
    }
}

/// The result of [`World::impulse_train`].
#[derive(Clone, Debug, PartialEq)]
pub struct ImpulseTrain {
    /// Sorted by time, then order.
    pub impulses: Vec<Impulse>,
    pub energy: EnergyBudget,
    /// True when `max_packets` was hit: the train is incomplete beyond the cut-offs.
    pub truncated: bool,
}

/// Neumaier-compensated sum, so that a path's time does not depend on rounding order.
#[derive(Default)]
struct CompensatedSum {
    sum: f64,
    compensation: f64,
}

impl CompensatedSum {
    fn add(&mut self, x: f64) {
        let t = self.sum + x;
        if self.sum.abs() >= x.abs() {
            self.compensation += (self.sum - t) + x;
        } else {
            self.compensation += (x - t) + self.sum;
        }
        self.sum = t;
    }

    fn total(&self) -> f64 {
        self.sum + self.compensation
    }
}

/// A packet of generation `k`: light that has just left `interface` in `dir`.
/// Two packets with equal keys took exactly the same time, so they merge.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct PacketKey {
    interface: usize,
    dir: Direction,
    /// Direction of the first leg out of L.
    start: Direction,
    /// Full crossings of each segment.
    counts: Vec<u32>,
}

/// Where a straight run starts.
#[derive(Clone, Copy)]
enum Entry {
    Light,
    Interface(usize),
}

/// A straight run of light through a segment, and on through transmissions.
struct Ray {
    entry: Entry,
    seg: usize,
    dir: Direction,
    /// `None` until the first leg out of L is done.
    start: Option<Direction>,
    counts: Vec<u32>,
    weight: f64,
    order: u32,
    /// Running optical path length, metres (for the time cut only).
    opl_m: f64,
}

struct Engine<'a> {
    world: &'a World,
    opts: &'a ImpulseOptions,
    /// `n d` of each segment, metres; infinite for the two unbounded ones.
    seg_opl_m: Vec<f64>,
    /// `opts.t_max_s`, seconds, with NaN read as infinity.
    t_max_s: f64,
    eye_seg: usize,
    light_seg: usize,
    impulses: Vec<Impulse>,
    energy: EnergyBudget,
    next: BTreeMap<PacketKey, f64>,
    truncated: bool,
}

impl<'a> Engine<'a> {
    fn new(world: &'a World, opts: &'a ImpulseOptions) -> Self {
        let n = world.interfaces.len();
        let seg_opl_m = (0..=n)
            .map(|s| {
                let ior = world.segment_ior.get(s).copied().unwrap_or(1.0);
                match (
                    s.checked_sub(1).and_then(|l| world.interfaces.get(l)),
                    world.interfaces.get(s),
                ) {
                    (Some(a), Some(b)) => (b.x_m - a.x_m) * ior,
                    _ => f64::INFINITY,
                }
            })
            .collect();
        Engine {
            world,
            opts,
            seg_opl_m,
            // A NaN limit would silently drop everything: read it as "no limit".
            t_max_s: if opts.t_max_s.is_nan() {
                f64::INFINITY
            } else {
                opts.t_max_s
            },
            eye_seg: world.segment_of(world.eye_m),
            light_seg: world.segment_of(world.light_m),
            impulses: Vec::new(),
            energy: EnergyBudget {
                emitted: 2.0,
                ..EnergyBudget::default()
            },
            next: BTreeMap::new(),
            truncated: false,
        }
    }

    fn ior(&self, seg: usize) -> f64 {
        self.world.segment_ior.get(seg).copied().unwrap_or(1.0)
    }

    fn x_of(&self, entry: Entry) -> f64 {
        match entry {
            Entry::Light => self.world.light_m,
            Entry::Interface(j) => self.world.interfaces.get(j).map_or(f64::NAN, |i| i.x_m),
        }
    }

    /// The interface met first going `dir` inside segment `seg`, if any.
    fn next_interface(&self, seg: usize, dir: Direction) -> Option<usize> {
        match dir {
            Direction::Right => (seg < self.world.interfaces.len()).then_some(seg),
            Direction::Left => seg.checked_sub(1),
        }
    }

    /// Optical length of the first leg, L to the first interface going `dir`, metres.
    fn start_leg_m(&self, dir: Direction) -> f64 {
        match self.next_interface(self.light_seg, dir) {
            Some(j) => {
                (self.x_of(Entry::Interface(j)) - self.world.light_m).abs()
                    * self.ior(self.light_seg)
            }
            None => f64::INFINITY,
        }
    }

    /// Optical path length of a path, metres: first leg + sum of `count * n d` over the
    /// segments + last leg, summed in a fixed order with compensation, so equal paths
    /// give bit-identical times.
    fn path_opl_m(&self, start: Option<Direction>, counts: &[u32], end_leg_m: f64) -> f64 {
        let mut sum = CompensatedSum::default();
        if let Some(dir) = start {
            sum.add(self.start_leg_m(dir));
        }
        for (&count, &opl) in counts.iter().zip(&self.seg_opl_m) {
            if count > 0 {
                sum.add(f64::from(count) * opl);
            }
        }
        sum.add(end_leg_m);
        sum.total()
    }

    fn run(&mut self) {
        let segments = self.seg_opl_m.len();
        for dir in [Direction::Left, Direction::Right] {
            self.walk(Ray {
                entry: Entry::Light,
                seg: self.light_seg,
                dir,
                start: None,
                counts: vec![0; segments],
                weight: 1.0,
                order: 0,
                opl_m: 0.0,
            });
        }
        let mut order = 0u32;
        while !self.next.is_empty() {
            order += 1;
            let generation = std::mem::take(&mut self.next);
            for (key, weight) in generation {
                if weight.is_nan() || weight < self.opts.min_weight {
                    self.energy.cut_weight += weight;
                    continue;
                }
                let seg = match key.dir {
                    Direction::Right => key.interface + 1,
                    Direction::Left => key.interface,
                };
                let opl_m = self.path_opl_m(Some(key.start), &key.counts, 0.0);
                self.walk(Ray {
                    entry: Entry::Interface(key.interface),
                    seg,
                    dir: key.dir,
                    start: Some(key.start),
                    counts: key.counts,
                    weight,
                    order,
                    opl_m,
                });
            }
        }
    }

    /// Follows one ray straight on until it escapes, is absorbed or cut, recording an
    /// impulse if it passes E towards the eye and queueing its reflections (the next
    /// term of the Neumann series).
    fn walk(&mut self, mut ray: Ray) {
        let look = self.world.look;
        loop {
            let entry_x_m = self.x_of(ray.entry);
            let ior = self.ior(ray.seg);
            // I*(E, w, t): light passing E while travelling away from the looking side.
            if ray.seg == self.eye_seg && ray.dir == look.opposite() {
                let ahead_m = (self.world.eye_m - entry_x_m) * ray.dir.sign();
                if ahead_m > 0.0 {
                    let opl_m = self.path_opl_m(ray.start, &ray.counts, ahead_m * ior);
                    let time_s = opl_m / C_M_PER_S;
                    if time_s <= self.t_max_s {
                        self.impulses.push(Impulse {
                            time_s,
                            weight: ray.weight,
                            order: ray.order,
                        });
                    }
                }
            }
            let Some(j) = self.next_interface(ray.seg, ray.dir) else {
                self.energy.escaped += ray.weight;
                return;
            };
            let Some(interface) = self.world.interfaces.get(j) else {
                self.energy.escaped += ray.weight;
                return;
            };
            // P: cross the segment, delayed by n d / c.
            ray.opl_m += (interface.x_m - entry_x_m).abs() * ior;
            match ray.entry {
                Entry::Light => ray.start = Some(ray.dir),
                Entry::Interface(_) => {
                    if let Some(count) = ray.counts.get_mut(ray.seg) {
                        *count += 1;
                    }
                }
            }
            if ray.opl_m / C_M_PER_S > self.t_max_s {
                self.energy.cut_time += ray.weight;
                return;
            }
            // S: scatter at the interface, which takes no time.
            let side = match ray.dir {
                Direction::Right => interface.left,
                Direction::Left => interface.right,
            };
            let reflected = ray.weight * side.reflectance;
            let transmitted = ray.weight * side.transmittance;
            self.energy.absorbed += ray.weight - reflected - transmitted;
            if reflected > 0.0 {
                if ray.order >= self.opts.max_order {
                    self.energy.cut_order += reflected;
                } else {
                    self.queue(
                        PacketKey {
                            interface: j,
                            dir: ray.dir.opposite(),
                            start: ray.start.unwrap_or(ray.dir),
                            counts: ray.counts.clone(),
                        },
                        reflected,
                    );
                }
            }
            if transmitted <= 0.0 {
                return;
            }
            if transmitted < self.opts.min_weight {
                self.energy.cut_weight += transmitted;
                return;
            }
            ray.weight = transmitted;
            ray.entry = Entry::Interface(j);
            ray.seg = match ray.dir {
                Direction::Right => j + 1,
                Direction::Left => j,
            };
        }
    }

    fn queue(&mut self, key: PacketKey, weight: f64) {
        if let Some(w) = self.next.get_mut(&key) {
            *w += weight;
        } else if self.next.len() >= self.opts.max_packets {
            self.truncated = true;
            self.energy.cut_packets += weight;
        } else {
            self.next.insert(key, weight);
        }
    }
}

/// Merges impulses of equal order whose times agree to `merge_rel` (relative), then
/// sorts by time (seconds), then order.
fn merge_impulses(mut impulses: Vec<Impulse>, merge_rel: f64) -> Vec<Impulse> {
    impulses.sort_by(|a, b| a.order.cmp(&b.order).then(a.time_s.total_cmp(&b.time_s)));
    let mut merged: Vec<Impulse> = Vec::with_capacity(impulses.len());
    for impulse in impulses {
        if let Some(last) = merged.last_mut()
            && last.order == impulse.order
            && (impulse.time_s - last.time_s).abs()
                <= merge_rel * impulse.time_s.abs().max(last.time_s.abs())
        {
            last.weight += impulse.weight;
            continue;
        }
        merged.push(impulse);
    }
    merged.sort_by(|a, b| a.time_s.total_cmp(&b.time_s).then(a.order.cmp(&b.order)));
    merged
}

/// The bin holding `time_s` on the axis `t0_s + b * dt_s` (seconds): bin `b` covers
/// `[t0_s + b dt_s, t0_s + (b + 1) dt_s)`, edges computed exactly as written. `None`
/// outside `0..bins`, or when `dt_s` is not a positive finite number.
pub fn bin_index(time_s: f64, t0_s: f64, dt_s: f64, bins: usize) -> Option<usize> {
    if !(dt_s > 0.0 && dt_s.is_finite() && t0_s.is_finite() && time_s.is_finite()) {
        return None;
    }
    if time_s < t0_s {
        return None;
    }
    let x = ((time_s - t0_s) / dt_s).floor();
    // `x == bins` may still round down into the last bin below.
    if x.is_nan() || x > bins as f64 {
        return None;
    }
    // `x` is within a rounding step of the true bin: settle it on the edges themselves.
    let mut b = x as usize;
    let start = |b: usize| t0_s + b as f64 * dt_s;
    if b > 0 && time_s < start(b) {
        b -= 1;
    } else if time_s >= start(b + 1) {
        b += 1;
    }
    (b < bins).then_some(b)
}

/// The TPRF integrated over time bins: each impulse's whole weight goes to the bin
/// holding its time (bin `b` covers `[t0_s + b dt_s, t0_s + (b + 1) dt_s)`, seconds);
/// impulses outside the window are dropped. All zeros when `dt_s` is not a positive
/// finite number.
pub fn binned(impulses: &[Impulse], t0_s: f64, dt_s: f64, bins: usize) -> Vec<f64> {
    let mut out = vec![0.0; bins];
    for impulse in impulses {
        if let Some(slot) = bin_index(impulse.time_s, t0_s, dt_s, bins).and_then(|b| out.get_mut(b))
        {
            *slot += impulse.weight;
        }
    }
    out
}

/// [`binned`] split by order: `result[k][b]` holds the order-`k` impulses of bin `b`.
/// One row per order from 0 to the highest order among `impulses` (none when empty).
pub fn binned_by_order(impulses: &[Impulse], t0_s: f64, dt_s: f64, bins: usize) -> Vec<Vec<f64>> {
    let rows = impulses
        .iter()
        .map(|i| i.order as usize + 1)
        .max()
        .unwrap_or(0);
    let mut out = vec![vec![0.0; bins]; rows];
    for impulse in impulses {
        if let Some(slot) = bin_index(impulse.time_s, t0_s, dt_s, bins)
            .and_then(|b| out.get_mut(impulse.order as usize)?.get_mut(b))
        {
            *slot += impulse.weight;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn bin_edges_follow_the_convention() {
        // 0.1 is not exact in binary: the edges are t0 + b * dt as computed.
        let (t0, dt) = (0.0, 0.1);
        for b in 0..100usize {
            let edge = t0 + b as f64 * dt;
            assert_eq!(bin_index(edge, t0, dt, 100), Some(b), "edge of bin {b}");
            let below = f64::from_bits(edge.to_bits() - 1);
            if b > 0 {
                assert_eq!(bin_index(below, t0, dt, 100), Some(b - 1));
            }
        }
        assert_eq!(bin_index(-1e-300, 0.0, 1.0, 4), None);
        assert_eq!(bin_index(4.0, 0.0, 1.0, 4), None);
        assert_eq!(bin_index(3.999, 0.0, 1.0, 4), Some(3));
        assert_eq!(bin_index(1.0, 0.0, 0.0, 4), None);
        assert_eq!(bin_index(1.0, 0.0, f64::NAN, 4), None);
        assert_eq!(bin_index(1e300, 0.0, 1e-300, 4), None);
    }

    #[test]
    fn compensated_sum_is_order_independent_here() {
        let terms = [1e16, 1.0, -1e16, 1.0];
        let mut s = CompensatedSum::default();
        for t in terms {
            s.add(t);
        }
        assert_eq!(s.total(), 2.0);
    }

    #[test]
    fn merge_joins_equal_order_only() {
        let imp = |time_s, order| Impulse {
            time_s,
            weight: 1.0,
            order,
        };
        let t: f64 = 1e-8;
        let next = f64::from_bits(t.to_bits() + 1);
        let merged = merge_impulses(
            vec![imp(t, 1), imp(next, 1), imp(t, 2), imp(2e-8, 1)],
            1e-15,
        );
        assert_eq!(merged.len(), 3);
        assert_eq!(
            merged[0],
            Impulse {
                time_s: t,
                weight: 2.0,
                order: 1
            }
        );
        assert_eq!(merged[1].order, 2);
        assert_eq!(merged[2].time_s, 2e-8);
    }

    #[test]
    fn virtual_interface_only_delays() {
        // A virtual interface between E and a mirror changes n, nothing else.
        let text = r#"{ "interfaces": [
            {"name": "V", "x_m": 1.0, "kind": "virtual"},
            {"name": "M", "x_m": 3.0, "left": {"reflectance": 1.0}} ],
            "eye_m": 0.0, "light_m": 0.0, "look": "right",
            "segment_ior": [1.0, 2.0, 1.0] }"#;
        let world = World::from_json_str(text).map_err(|e| e.to_string());
        let Ok(world) = world else {
            panic!("{world:?}");
        };
        let imps = world.impulses(&ImpulseOptions::default());
        assert_eq!(imps.len(), 1);
        let expected_s = 2.0 * (1.0 + 2.0 * 2.0) / C_M_PER_S;
        assert!((imps[0].time_s - expected_s).abs() <= 1e-15 * expected_s);
        assert_eq!(imps[0].weight, 1.0);
        assert_eq!(imps[0].order, 1);
    }

    #[test]
    fn packets_merge_by_path() {
        // Three partly reflecting interfaces: many distinct paths share crossing
        // counts; the energy still balances and the work stays small.
        let text = r#"{ "interfaces": [
            {"x_m": 1.0, "left": {"reflectance": 0.5, "transmittance": 0.5},
                         "right": {"reflectance": 0.5, "transmittance": 0.5}},
            {"x_m": 2.3, "left": {"reflectance": 0.5, "transmittance": 0.5},
                         "right": {"reflectance": 0.5, "transmittance": 0.5}},
            {"x_m": 4.1, "left": {"reflectance": 0.5, "transmittance": 0.5},
                         "right": {"reflectance": 0.5, "transmittance": 0.5}} ],
            "eye_m": 0.0, "light_m": 0.0, "look": "right" }"#;
        let Ok(world) = World::from_json_str(text) else {
            panic!("valid world");
        };
        let train = world.impulse_train(&ImpulseOptions::default());
        assert!(!train.truncated);
        assert!(train.energy.imbalance().abs() < 1e-12, "{:?}", train.energy);
        assert!(train.energy.cut_total() < 1e-6, "{:?}", train.energy);
    }
}
