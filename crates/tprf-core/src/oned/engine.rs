//! The impulse-train engine: the Neumann series of the 1-D world evaluated generation
//! by generation, with packets merged by path and an energy budget of what escaped,
//! was absorbed or was cut.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::{Direction, World};
use crate::units::C_M_PER_S;

impl World {
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
    /// Memory limit, bytes, on what the enumeration holds at once: the live packets of
    /// two orders ([`ImpulseOptions::packet_bytes`] each, which grows with the number of
    /// interfaces) and the impulses recorded (twice `IMPULSE_BYTES` each, for the final
    /// merge). Beyond it packets and impulses are dropped and the train reports
    /// `truncated`. Default 256 MiB.
    pub max_bytes: u64,
}

/// Bytes an [`Impulse`] takes.
pub const IMPULSE_BYTES: u64 = std::mem::size_of::<Impulse>() as u64;

impl ImpulseOptions {
    /// Bytes one live packet of a world with `interfaces` interfaces takes: its key
    /// (with one crossing count per segment, `interfaces + 1` of 4 B), its weight and
    /// its share of the map's nodes.
    pub fn packet_bytes(interfaces: usize) -> u64 {
        let key = std::mem::size_of::<PacketKey>() + std::mem::size_of::<f64>();
        (key as u64 + 16).saturating_add(4 * (interfaces as u64 + 1))
    }

    /// The most live packets `max_bytes` holds for a world with `interfaces` interfaces.
    pub fn max_packets(&self, interfaces: usize) -> u64 {
        self.max_bytes / Self::packet_bytes(interfaces)
    }
}

impl Default for ImpulseOptions {
    fn default() -> Self {
        ImpulseOptions {
            min_weight: 1e-12,
            t_max_s: f64::INFINITY,
            max_order: 1000,
            merge_rel: 1e-15,
            max_bytes: 256 << 20,
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
    /// Dropped by the `max_bytes` limit.
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
    /// True when `max_bytes` was reached: the train is incomplete beyond the cut-offs.
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
    /// Packets of the order being walked.
    current_len: usize,
    /// [`ImpulseOptions::packet_bytes`] of this world.
    packet_bytes: u64,
    truncated: bool,
}

impl<'a> Engine<'a> {
    fn new(world: &'a World, opts: &'a ImpulseOptions) -> Self {
        let n = world.interfaces().len();
        let seg_opl_m = (0..=n)
            .map(|s| {
                let ior = world.segment_ior().get(s).copied().unwrap_or(1.0);
                match (
                    s.checked_sub(1).and_then(|l| world.interfaces().get(l)),
                    world.interfaces().get(s),
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
            eye_seg: world.segment_of(world.eye_m()),
            light_seg: world.segment_of(world.light_m()),
            impulses: Vec::new(),
            energy: EnergyBudget {
                emitted: 2.0,
                ..EnergyBudget::default()
            },
            next: BTreeMap::new(),
            current_len: 0,
            packet_bytes: ImpulseOptions::packet_bytes(n),
            truncated: false,
        }
    }

    /// Bytes held now: the live packets of two orders and the impulses (counted twice,
    /// for the final merge).
    fn bytes_held(&self) -> u64 {
        let packets = (self.current_len + self.next.len()) as u64;
        packets
            .saturating_mul(self.packet_bytes)
            .saturating_add((self.impulses.len() as u64).saturating_mul(2 * IMPULSE_BYTES))
    }

    /// Whether one more item of `bytes` stays inside `max_bytes`.
    fn fits(&self, bytes: u64) -> bool {
        self.bytes_held().saturating_add(bytes) <= self.opts.max_bytes
    }

    fn ior(&self, seg: usize) -> f64 {
        self.world.segment_ior().get(seg).copied().unwrap_or(1.0)
    }

    fn x_of(&self, entry: Entry) -> f64 {
        match entry {
            Entry::Light => self.world.light_m(),
            Entry::Interface(j) => self.world.interfaces().get(j).map_or(f64::NAN, |i| i.x_m),
        }
    }

    /// The interface met first going `dir` inside segment `seg`, if any.
    fn next_interface(&self, seg: usize, dir: Direction) -> Option<usize> {
        match dir {
            Direction::Right => (seg < self.world.interfaces().len()).then_some(seg),
            Direction::Left => seg.checked_sub(1),
        }
    }

    /// Optical length of the first leg, L to the first interface going `dir`, metres.
    fn start_leg_m(&self, dir: Direction) -> f64 {
        match self.next_interface(self.light_seg, dir) {
            Some(j) => {
                (self.x_of(Entry::Interface(j)) - self.world.light_m()).abs()
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
            self.current_len = generation.len();
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
        let look = self.world.look();
        loop {
            let entry_x_m = self.x_of(ray.entry);
            let ior = self.ior(ray.seg);
            // I*(E, w, t): light passing E while travelling away from the looking side.
            if ray.seg == self.eye_seg && ray.dir == look.opposite() {
                let ahead_m = (self.world.eye_m() - entry_x_m) * ray.dir.sign();
                if ahead_m > 0.0 {
                    let opl_m = self.path_opl_m(ray.start, &ray.counts, ahead_m * ior);
                    let time_s = opl_m / C_M_PER_S;
                    if time_s <= self.t_max_s && !self.fits(2 * IMPULSE_BYTES) {
                        self.truncated = true;
                    } else if time_s <= self.t_max_s {
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
            let Some(interface) = self.world.interfaces().get(j) else {
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
        } else if !self.fits(self.packet_bytes) {
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

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn a_byte_limit_truncates_a_wide_world_and_keeps_its_energy() {
        // 200 interfaces that reflect and pass half: far more distinct paths than 1 MiB of
        // packets (about 870 B each here) holds. The run ends, says it is incomplete,
        // and the dropped light is counted.
        let side = r#"{"reflectance": 0.5, "transmittance": 0.5}"#;
        let interfaces: Vec<String> = (0..200)
            .map(|i| {
                let x = 1.0 + f64::from(i) * 0.01;
                format!(r#"{{"x_m": {x}, "left": {side}, "right": {side}}}"#)
            })
            .collect();
        let text = format!(
            r#"{{"interfaces": [{}], "eye_m": 0.0, "light_m": 0.0, "look": "right"}}"#,
            interfaces.join(",")
        );
        let Ok(world) = World::from_json_str(&text) else {
            panic!("valid world");
        };
        let opts = ImpulseOptions {
            max_bytes: 1 << 20,
            ..ImpulseOptions::default()
        };
        let train = world.impulse_train(&opts);
        assert!(train.truncated);
        assert!(train.energy.cut_packets > 0.0, "{:?}", train.energy);
        assert!(train.energy.imbalance().abs() < 1e-12, "{:?}", train.energy);
        // The impulses held (before merging) stayed inside the limit.
        assert!(train.impulses.len() as u64 * 2 * IMPULSE_BYTES <= opts.max_bytes);
    }
}
