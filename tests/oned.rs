//! The 1-D world (paper Figure 4) against closed forms derived by hand.
//!
//! Reference world: boundary Z left of E and L; A partly transparent (left side rA,
//! tA; right side rA', tA'); B opaque (left side rB). With E = L left of A, looking
//! right, light reaches E travelling left only by
//! - reflecting once off A: weight rA, time 2 n1 d(E,A) / c, order 1;
//! - crossing A, bouncing k + 1 times off B and k times off A's right side, crossing A
//!   back: weight tA tA' rB^(k+1) rA'^k, time (2 n1 d(E,A) + 2 (k+1) n2 d(A,B)) / c,
//!   order 2k + 1;
//!
//! and the light emitted leftwards is absorbed by Z. The total is the geometric series
//! rA + tA tA' rB / (1 - rA' rB).

use std::path::{Path, PathBuf};

use tprf::cli::print_oned;
use tprf_core::oned::{
    Direction, Impulse, ImpulseOptions, InterfaceKind, InterfaceSpec, Side, World, WorldError,
    WorldFile, binned, binned_by_order,
};
use tprf_core::units::C_M_PER_S;

const C: f64 = C_M_PER_S;

struct Params {
    x_e: f64,
    x_l: f64,
    x_z: f64,
    x_a: f64,
    x_b: f64,
    r_a: f64,
    t_a: f64,
    r_a2: f64,
    t_a2: f64,
    r_b: f64,
    /// Index of the segments Z-A... : [left of Z, Z-A, A-B, right of B].
    ior: [f64; 4],
    look: Direction,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            x_e: 0.0,
            x_l: 0.0,
            x_z: -1.0,
            x_a: 10.0,
            x_b: 25.0,
            r_a: 0.3,
            t_a: 0.6,
            r_a2: 0.25,
            t_a2: 0.55,
            r_b: 0.8,
            ior: [1.0; 4],
            look: Direction::Right,
        }
    }
}

fn side(reflectance: f64, transmittance: f64) -> Side {
    Side {
        reflectance,
        transmittance,
    }
}

impl Params {
    fn file(&self) -> WorldFile {
        WorldFile {
            interfaces: vec![
                InterfaceSpec {
                    name: Some("Z".into()),
                    x_m: self.x_z,
                    kind: InterfaceKind::Boundary,
                    left: None,
                    right: None,
                },
                InterfaceSpec {
                    name: Some("A".into()),
                    x_m: self.x_a,
                    kind: InterfaceKind::Real,
                    left: Some(side(self.r_a, self.t_a)),
                    right: Some(side(self.r_a2, self.t_a2)),
                },
                InterfaceSpec {
                    name: Some("B".into()),
                    x_m: self.x_b,
                    kind: InterfaceKind::Real,
                    left: Some(side(self.r_b, 0.0)),
                    right: None,
                },
            ],
            eye_m: self.x_e,
            look: self.look,
            light_m: self.x_l,
            segment_ior: Some(self.ior.to_vec()),
        }
    }

    fn world(&self) -> World {
        match World::new(self.file()) {
            Ok(world) => world,
            Err(e) => panic!("reference world rejected: {e}"),
        }
    }

    /// The closed form for E = L left of A (see the file header): impulse `i` of the
    /// train, `i = 0` the reflection off A, `i = k + 1` the k-th one from B.
    fn closed_form(&self, i: usize) -> Impulse {
        let ea = self.ior[1] * (self.x_a - self.x_e);
        let ab = self.ior[2] * (self.x_b - self.x_a);
        if i == 0 {
            return Impulse {
                time_s: 2.0 * ea / C,
                weight: self.r_a,
                order: 1,
            };
        }
        let k = (i - 1) as i32;
        Impulse {
            time_s: (2.0 * ea + 2.0 * f64::from(k + 1) * ab) / C,
            weight: self.t_a * self.t_a2 * self.r_b.powi(k + 1) * self.r_a2.powi(k),
            order: 2 * k as u32 + 1,
        }
    }

    fn total_weight(&self) -> f64 {
        self.r_a + self.t_a * self.t_a2 * self.r_b / (1.0 - self.r_a2 * self.r_b)
    }
}

fn rel_close(got: f64, want: f64, rel: f64) -> bool {
    (got - want).abs() <= rel * want.abs().max(f64::MIN_POSITIVE)
}

fn assert_impulse(got: &Impulse, want: &Impulse, what: &str) {
    assert!(
        rel_close(got.time_s, want.time_s, 1e-12),
        "{what}: time {} s, want {} s",
        got.time_s,
        want.time_s
    );
    assert!(
        rel_close(got.weight, want.weight, 1e-12),
        "{what}: weight {}, want {}",
        got.weight,
        want.weight
    );
    assert_eq!(got.order, want.order, "{what}: order");
}

fn defaults() -> ImpulseOptions {
    ImpulseOptions::default()
}

#[test]
fn first_impulses_match_the_closed_form() {
    let p = Params::default();
    let train = p.world().impulses(&defaults());
    assert!(train.len() > 12, "only {} impulses", train.len());
    for (i, got) in train.iter().take(12).enumerate() {
        assert_impulse(got, &p.closed_form(i), &format!("impulse {i}"));
    }
    // Every impulse of the train is one of the closed form's, in order.
    for (i, got) in train.iter().enumerate() {
        assert_impulse(got, &p.closed_form(i), &format!("impulse {i}"));
    }
    // And the train stops where the weights fall below the cut-off.
    let last = p.closed_form(train.len());
    assert!(
        last.weight < 1e-11,
        "train stopped at weight {}",
        last.weight
    );
}

#[test]
fn total_weight_is_the_geometric_series() {
    for (r_a2, r_b) in [(0.25, 0.8), (0.95, 0.99), (0.0, 1.0)] {
        let p = Params {
            r_a2,
            t_a2: 1.0 - r_a2,
            r_b,
            ..Params::default()
        };
        let total: f64 = p
            .world()
            .impulses(&defaults())
            .iter()
            .map(|i| i.weight)
            .sum();
        // The dropped tail is below 1e-12 / (1 - rA' rB) per cut packet.
        let tol = 1e-12 / (1.0 - r_a2 * r_b) + 1e-13;
        assert!(
            (total - p.total_weight()).abs() <= tol,
            "rA' {r_a2} rB {r_b}: total {total}, series {}",
            p.total_weight()
        );
    }
}

#[test]
fn pulse_spacing_is_the_round_trip_a_b() {
    // The paper's observation (section 5): the distance A-B shows as the separation
    // of the pulses, 2 d(A, B) / c.
    let p = Params::default();
    let train = p.world().impulses(&defaults());
    let spacing_s = 2.0 * (p.x_b - p.x_a) / C;
    assert!(train.len() > 10);
    for pair in train[1..10].windows(2) {
        let gap_s = pair[1].time_s - pair[0].time_s;
        assert!(
            rel_close(gap_s, spacing_s, 1e-9),
            "gap {gap_s} s, want {spacing_s} s"
        );
    }
    // The first gap is the round trip A-B as well: E sees A, then B through A.
    let first_gap_s = train[1].time_s - train[0].time_s;
    assert!(rel_close(first_gap_s, spacing_s, 1e-9));
}

#[test]
fn refractive_index_delays_by_n_d_over_c() {
    let vacuum = Params::default();
    let glass = Params {
        ior: [1.0, 1.5, 1.0, 1.0],
        ..Params::default()
    };
    let water = Params {
        ior: [1.0, 1.5, 1.33, 1.0],
        ..Params::default()
    };
    let (tv, tg, tw) = (
        vacuum.world().impulses(&defaults()),
        glass.world().impulses(&defaults()),
        water.world().impulses(&defaults()),
    );
    assert_eq!(tv.len(), tg.len());
    let d_ea = glass.x_a - glass.x_e;
    // Each path crosses E-A twice: n = 1.5 adds 2 (1.5 - 1) d / c to every impulse.
    let extra_s = 2.0 * (1.5 - 1.0) * d_ea / C;
    for (v, g) in tv.iter().zip(&tg) {
        assert!(rel_close(g.time_s - v.time_s, extra_s, 1e-9));
        assert_eq!(g.weight, v.weight);
    }
    assert!(rel_close(tg[0].time_s, 2.0 * 1.5 * d_ea / C, 1e-12));
    for (i, got) in tw.iter().take(10).enumerate() {
        assert_impulse(
            got,
            &water.closed_form(i),
            &format!("n = 1.33, impulse {i}"),
        );
    }
    // A-B in water: the pulses are 1.33 times further apart.
    let spacing_s = 2.0 * 1.33 * (water.x_b - water.x_a) / C;
    assert!(rel_close(tw[3].time_s - tw[2].time_s, spacing_s, 1e-9));
}

#[test]
fn light_behind_the_eye_adds_no_direct_pulse() {
    // L left of E: its rightward pulse passes E going right, unseen by E looking right.
    let p = Params {
        x_l: -0.5,
        ..Params::default()
    };
    let train = p.world().impulses(&defaults());
    let (d_la, d_ae, d_ab) = (p.x_a - p.x_l, p.x_a - p.x_e, p.x_b - p.x_a);
    assert_impulse(
        &train[0],
        &Impulse {
            time_s: (d_la + d_ae) / C,
            weight: p.r_a,
            order: 1,
        },
        "A",
    );
    for k in 0..5i32 {
        let want = Impulse {
            time_s: (d_la + d_ae + 2.0 * f64::from(k + 1) * d_ab) / C,
            weight: p.t_a * p.t_a2 * p.r_b.powi(k + 1) * p.r_a2.powi(k),
            order: 2 * k as u32 + 1,
        };
        assert_impulse(&train[k as usize + 1], &want, &format!("B, k = {k}"));
    }
}

#[test]
fn light_in_front_of_the_eye_is_seen_directly() {
    // L between E and A: its leftward pulse reaches E from the right at d(L,E)/c.
    let p = Params {
        x_l: 2.0,
        ..Params::default()
    };
    let train = p.world().impulses(&defaults());
    assert_impulse(
        &train[0],
        &Impulse {
            time_s: 2.0 / C,
            weight: 1.0,
            order: 0,
        },
        "direct",
    );
    let (d_la, d_ae) = (p.x_a - p.x_l, p.x_a - p.x_e);
    assert_impulse(
        &train[1],
        &Impulse {
            time_s: (d_la + d_ae) / C,
            weight: p.r_a,
            order: 1,
        },
        "A",
    );
}

#[test]
fn light_between_a_and_b_reaches_the_eye_through_a() {
    // L between A and B: the direct path crosses A (order 0: transmission is not a
    // reflection); then B's echo (order 1), then A's back side and B (order 2), ...
    let p = Params {
        x_l: 15.0,
        ..Params::default()
    };
    let train = p.world().impulses(&defaults());
    let (t_a2, r_a2, r_b) = (p.t_a2, p.r_a2, p.r_b);
    let want = [
        (15.0, t_a2, 0),
        (35.0, r_b * t_a2, 1),
        (45.0, r_a2 * r_b * t_a2, 2),
        (65.0, r_b * r_a2 * r_b * t_a2, 3),
        (75.0, r_a2 * r_b * r_a2 * r_b * t_a2, 4),
    ];
    for (i, (opl_m, weight, order)) in want.into_iter().enumerate() {
        let expected = Impulse {
            time_s: opl_m / C,
            weight,
            order,
        };
        assert_impulse(&train[i], &expected, &format!("impulse {i}"));
        assert!(rel_close(train[i].opl_m(), opl_m, 1e-12));
    }
}

#[test]
fn looking_left_sees_only_light_from_the_left() {
    // Left of E there is only the boundary Z: with L at E or right of it, nothing.
    for x_l in [0.0, 2.0, 15.0] {
        let p = Params {
            x_l,
            look: Direction::Left,
            ..Params::default()
        };
        let train = p.world().impulses(&defaults());
        assert!(train.is_empty(), "L at {x_l}: {train:?}");
    }
    // L between Z and E: its rightward pulse only.
    let p = Params {
        x_l: -0.5,
        look: Direction::Left,
        ..Params::default()
    };
    let train = p.world().impulses(&defaults());
    assert_eq!(train.len(), 1, "{train:?}");
    assert_impulse(
        &train[0],
        &Impulse {
            time_s: 0.5 / C,
            weight: 1.0,
            order: 0,
        },
        "direct",
    );
    // A reflecting Z instead of a boundary: the eye looking left sees Z's echo of
    // everything that travels left past E: first the pulse itself, 2 d(E,Z)/c.
    let mut file = Params {
        look: Direction::Left,
        ..Params::default()
    }
    .file();
    file.interfaces[0].kind = InterfaceKind::Real;
    file.interfaces[0].right = Some(side(0.5, 0.0));
    let Ok(world) = World::new(file) else {
        panic!("reflecting Z rejected");
    };
    let train = world.impulses(&defaults());
    assert_impulse(
        &train[0],
        &Impulse {
            time_s: 2.0 / C,
            weight: 0.5,
            order: 1,
        },
        "Z",
    );
    // Then Z's echo of A's reflection: 0.5 rA at (2 d(E,A) + 2 d(E,Z)) / c, order 2.
    assert_impulse(
        &train[1],
        &Impulse {
            time_s: 22.0 / C,
            weight: 0.5 * 0.3,
            order: 2,
        },
        "Z after A",
    );
}

#[test]
fn binning_conserves_the_weight_inside_the_window() {
    let p = Params::default();
    let train = p.world().impulses(&defaults());
    let total: f64 = train.iter().map(|i| i.weight).sum();
    // A window holding everything.
    let last_s = train.last().map_or(0.0, |i| i.time_s);
    let bins = binned(&train, 0.0, 1e-9, (last_s / 1e-9) as usize + 2);
    let sum: f64 = bins.iter().sum();
    assert!((sum - total).abs() <= 1e-12 * total);
    // A window that cuts the train: only the impulses in [t0, t0 + bins dt) count.
    let (t0_s, dt_s, n) = (100e-9, 0.7e-9, 500);
    let bins = binned(&train, t0_s, dt_s, n);
    assert_eq!(bins.len(), n);
    let end_s = t0_s + n as f64 * dt_s;
    let inside: f64 = train
        .iter()
        .filter(|i| i.time_s >= t0_s && i.time_s < end_s)
        .map(|i| i.weight)
        .sum();
    let sum: f64 = bins.iter().sum();
    assert!(inside > 0.0 && inside < total);
    assert!((sum - inside).abs() <= 1e-12 * inside);
    // Each impulse lands in the bin that holds its time.
    for impulse in train
        .iter()
        .filter(|i| i.time_s >= t0_s && i.time_s < end_s)
    {
        let b = ((impulse.time_s - t0_s) / dt_s) as usize;
        assert!(bins[b] >= impulse.weight * (1.0 - 1e-12));
    }
    // Per order: the rows add up to the plain binning.
    let by_order = binned_by_order(&train, t0_s, dt_s, n);
    let max_order = train.iter().map(|i| i.order).max().unwrap_or(0);
    assert_eq!(by_order.len(), max_order as usize + 1);
    for b in 0..n {
        let s: f64 = by_order.iter().map(|row| row[b]).sum();
        assert!((s - bins[b]).abs() <= 1e-15);
    }
    // Order 0 never occurs with E = L, so its row is empty.
    assert!(by_order[0].iter().all(|&v| v == 0.0));
    // A nonsensical axis bins nothing.
    assert!(binned(&train, 0.0, 0.0, 4).iter().all(|&v| v == 0.0));
    assert!(binned(&train, 0.0, -1e-9, 4).iter().all(|&v| v == 0.0));
}

#[test]
fn scaling_the_world_stretches_time() {
    let p = Params::default();
    let world = p.world();
    let base = world.impulses(&defaults());
    for scale in [1e-3, 7.0, 1e3] {
        let Ok(scaled) = world.scaled(scale) else {
            panic!("scaled world rejected");
        };
        let train = scaled.impulses(&defaults());
        assert_eq!(train.len(), base.len());
        for (a, b) in base.iter().zip(&train) {
            assert!(rel_close(b.time_s, a.time_s * scale, 1e-12));
            assert!(rel_close(b.weight, a.weight, 1e-12));
            assert_eq!(a.order, b.order);
        }
    }
    for scale in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            world.scaled(scale),
            Err(WorldError::BadScale { .. })
        ));
    }
}

#[test]
fn energy_is_accounted_for() {
    let p = Params::default();
    let train = p.world().impulse_train(&defaults());
    let e = train.energy;
    assert_eq!(e.emitted, 2.0);
    assert!(e.imbalance().abs() < 1e-12, "{e:?}");
    assert!(!train.truncated);
    // Nothing escapes: Z and B close the world. A's and B's losses and Z take it all.
    assert_eq!(e.escaped, 0.0);
    assert!(e.cut_total() < 1e-10);
}

#[test]
fn cut_offs_limit_order_and_time() {
    let p = Params::default();
    let world = p.world();
    let opts = ImpulseOptions {
        max_order: 3,
        ..ImpulseOptions::default()
    };
    let train = world.impulse_train(&opts);
    // Orders 1, 1, 3: the closed form's first three impulses.
    assert_eq!(train.impulses.len(), 3);
    for (i, got) in train.impulses.iter().enumerate() {
        assert_impulse(got, &p.closed_form(i), &format!("impulse {i}"));
    }
    assert!(train.energy.cut_order > 0.0);
    assert!(train.energy.imbalance().abs() < 1e-12);

    // Halfway between the 5th and 6th impulse: the 5 first survive.
    let t_max_s = 0.5 * (p.closed_form(4).time_s + p.closed_form(5).time_s);
    let opts = ImpulseOptions {
        t_max_s,
        ..ImpulseOptions::default()
    };
    let train = world.impulse_train(&opts);
    assert_eq!(train.impulses.len(), 5);
    assert!(train.impulses.iter().all(|i| i.time_s <= t_max_s));
    assert!(train.energy.cut_time > 0.0);
    assert!(train.energy.imbalance().abs() < 1e-12);
}

#[test]
fn lossless_cavity_stops_at_max_order() {
    // Perfect mirrors around E = L: the weight never decays, only max_order ends it.
    let text = r#"{ "interfaces": [
        {"name": "M1", "x_m": -1.0, "right": {"reflectance": 1.0}},
        {"name": "M2", "x_m": 2.0, "left": {"reflectance": 1.0}} ],
        "eye_m": 0.0, "light_m": 0.0, "look": "right" }"#;
    let world = World::from_json_str(text).map_err(|e| e.to_string());
    let Ok(world) = world else {
        panic!("{world:?}")
    };
    let opts = ImpulseOptions {
        max_order: 50,
        ..ImpulseOptions::default()
    };
    let train = world.impulse_train(&opts);
    // Arrivals from the right: the rightward pulse after 1, 3, 5, ... reflections and
    // the leftward one after 2, 4, ...: one per order 1..=50, every 2 d(M1,M2)/c
    // apart within each family.
    assert_eq!(train.impulses.len(), 50);
    assert!(train.impulses.iter().all(|i| i.weight == 1.0));
    assert_impulse(
        &train.impulses[0],
        &Impulse {
            time_s: 4.0 / C,
            weight: 1.0,
            order: 1,
        },
        "M2",
    );
    assert_impulse(
        &train.impulses[1],
        &Impulse {
            time_s: 6.0 / C,
            weight: 1.0,
            order: 2,
        },
        "M1 then M2",
    );
    assert_eq!(train.energy.cut_order, 2.0);
}

#[test]
fn figure4_asset_runs_through_the_cli() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/oned/figure4.json");
    let world = match World::from_path(&path) {
        Ok(world) => world,
        Err(e) => panic!("{e}"),
    };
    assert_eq!(world.look(), Direction::Right);
    let names: Vec<&str> = world.interfaces().iter().map(|i| i.name.as_str()).collect();
    assert_eq!(names, ["Z", "A", "B"]);
    let train = world.impulses(&defaults());
    // Figure 4(c): A's echo, then B's echoes spaced 2 d(A,B)/c = 100.07 ns.
    assert_eq!(train[0].order, 1);
    assert!(rel_close(train[0].opl_m(), 20.5, 1e-12));
    assert!(rel_close(train[0].weight, 0.3, 1e-12));
    assert!(rel_close(train[1].opl_m(), 50.5, 1e-12));
    assert!(rel_close(train[1].weight, 0.6 * 0.6 * 0.8, 1e-12));

    let mut out = Vec::new();
    let result = print_oned(&path, Some((0.0, 1e-9, 400)), &mut out);
    assert!(result.is_ok(), "{result:?}");
    let text = String::from_utf8_lossy(&out);
    let rows: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(rows.len(), train.len() + 400);
    // First impulse row: time_ns, opl_m, weight, order.
    let first: Vec<f64> = rows[0]
        .split_whitespace()
        .filter_map(|s| s.parse().ok())
        .collect();
    assert_eq!(first.len(), 4);
    assert!((first[0] - 20.5 / C * 1e9).abs() < 1e-6);
    assert!((first[1] - 20.5).abs() < 1e-6);
    assert!((first[2] - 0.3).abs() < 1e-9);
    assert_eq!(first[3], 1.0);
    // The binned rows add up to the weight inside the 400 ns window.
    let binned_sum: f64 = rows[train.len()..]
        .iter()
        .filter_map(|l| l.split_whitespace().nth(2)?.parse::<f64>().ok())
        .sum();
    let inside: f64 = train
        .iter()
        .filter(|i| i.time_s < 400e-9)
        .map(|i| i.weight)
        .sum();
    assert!((binned_sum - inside).abs() < 1e-9);

    // Without bins: only the impulses.
    let mut out = Vec::new();
    assert!(print_oned(&path, None, &mut out).is_ok());
    let text = String::from_utf8_lossy(&out);
    assert_eq!(
        text.lines().filter(|l| !l.starts_with('#')).count(),
        train.len()
    );
}

#[test]
fn world_deserialises_and_round_trips() {
    let Ok(text) = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/oned/figure4.json"),
    ) else {
        panic!("figure4.json unreadable");
    };
    let world: World = match serde_json::from_str(&text) {
        Ok(w) => w,
        Err(e) => panic!("{e}"),
    };
    let again = serde_json::to_string(&world)
        .ok()
        .and_then(|s| serde_json::from_str::<World>(&s).ok());
    assert_eq!(again.as_ref(), Some(&world));
    // Unsorted input is sorted; ior defaults to 1; look may be given as a sign.
    let text = r#"{ "interfaces": [ {"name": "B", "x_m": 25.0, "left": {"reflectance": 0.8}},
                                   {"name": "A", "x_m": 10.0} ],
                   "eye_m": 0.0, "light_m": 0.0, "look": -1 }"#;
    let Ok(world) = World::from_json_str(text) else {
        panic!("valid world rejected");
    };
    assert_eq!(world.interfaces()[0].name, "A");
    assert_eq!(world.segment_ior(), [1.0, 1.0, 1.0]);
    assert_eq!(world.look(), Direction::Left);
    // A missing side is opaque and black.
    assert_eq!(world.interfaces()[0].left, Side::default());
    // Serde errors from the validating deserialiser carry the validation message.
    let bad = text.replace("0.8", "1.8");
    let err = serde_json::from_str::<World>(&bad)
        .err()
        .map(|e| e.to_string());
    assert!(
        err.as_deref().is_some_and(|e| e.contains("outside [0, 1]")),
        "{err:?}"
    );
}

fn error_of(text: &str) -> WorldError {
    match World::from_json_str(text) {
        Ok(w) => panic!("accepted a bad world: {w:?}"),
        Err(e) => {
            // Every message is a readable sentence.
            assert!(!e.to_string().is_empty());
            e
        }
    }
}

#[test]
fn bad_files_give_errors_not_panics() {
    let wrap = |interfaces: &str, rest: &str| {
        format!(
            r#"{{ "interfaces": [{interfaces}], "eye_m": 0.0, "light_m": 0.0, "look": "right" {rest} }}"#
        )
    };
    let a = r#"{"name": "A", "x_m": 10.0, "left": {"reflectance": 0.3, "transmittance": 0.6}}"#;

    assert!(matches!(error_of("not json"), WorldError::Json(_)));
    assert!(matches!(error_of("{}"), WorldError::Json(_)));
    assert!(matches!(
        error_of(&wrap(a, r#", "colour": "red""#)),
        WorldError::Json(_)
    ));
    assert!(matches!(
        error_of(&wrap(a, "").replace("\"right\" ", "\"up\" ")),
        WorldError::Json(_)
    ));
    assert!(matches!(
        error_of(&wrap(r#"{"x_m": 1e400}"#, "")),
        WorldError::Json(_)
    ));
    assert!(matches!(
        error_of(&wrap(r#"{"x_m": 1.0, "kind": "mirror"}"#, "")),
        WorldError::Json(_)
    ));
    assert!(matches!(
        error_of(&wrap(r#"{"x_m": 1.0, "left": {"reflectance": 1.2}}"#, "")),
        WorldError::OutOfRange { .. }
    ));
    assert!(matches!(
        error_of(&wrap(
            r#"{"x_m": 1.0, "right": {"transmittance": -0.1}}"#,
            ""
        )),
        WorldError::OutOfRange { .. }
    ));
    let gain = error_of(&wrap(
        r#"{"name": "G", "x_m": 1.0, "left": {"reflectance": 0.7, "transmittance": 0.7}}"#,
        "",
    ));
    assert!(matches!(gain, WorldError::EnergyGain { .. }));
    assert!(gain.to_string().contains("'G'"), "{gain}");
    // r + t = 1 exactly (up to decimal rounding) is fine.
    assert!(
        World::from_json_str(&wrap(
            r#"{"x_m": 1.0, "left": {"reflectance": 0.7, "transmittance": 0.3}}"#,
            ""
        ))
        .is_ok()
    );
    assert!(matches!(
        error_of(&wrap(&format!("{a}, {a}"), "")),
        WorldError::DuplicateName { .. }
    ));
    assert!(matches!(
        error_of(&wrap(r#"{"x_m": 3.0}, {"x_m": 3.0}"#, "")),
        WorldError::DuplicatePosition { .. }
    ));
    assert!(matches!(
        error_of(&wrap(a, r#", "segment_ior": [1.0, 1.0, 1.0]"#)),
        WorldError::IorCount {
            got: 3,
            expected: 2,
            ..
        }
    ));
    assert!(matches!(
        error_of(&wrap(a, r#", "segment_ior": [1.0, 0.5]"#)),
        WorldError::IorBelowOne { index: 1, .. }
    ));
    assert!(matches!(
        error_of(&wrap(r#"{"x_m": 0.0}"#, "")),
        WorldError::OnInterface { what: "eye", .. }
    ));
    assert!(matches!(
        error_of(&wrap(a, "").replace("\"light_m\": 0.0", "\"light_m\": 10.0")),
        WorldError::OnInterface { what: "light", .. }
    ));
    assert!(matches!(
        error_of(&wrap(
            r#"{"x_m": -1.0, "kind": "boundary", "right": {"reflectance": 0.5}}"#,
            ""
        )),
        WorldError::SideOnFixedKind { .. }
    ));
    assert!(matches!(
        error_of(&wrap(r#"{"x_m": 1.0, "kind": "virtual", "left": {}}"#, "")),
        WorldError::SideOnFixedKind { .. }
    ));
    assert!(matches!(
        error_of(
            &wrap(r#"{"x_m": 1.0, "kind": "boundary"}"#, "")
                .replace("\"light_m\": 0.0", "\"light_m\": 2.0")
        ),
        WorldError::Separated { .. }
    ));

    // Programmatic worlds can hold what JSON cannot.
    let mut file = Params::default().file();
    file.eye_m = f64::NAN;
    assert!(matches!(
        World::new(file),
        Err(WorldError::NotFinite { .. })
    ));
    let mut file = Params::default().file();
    file.interfaces[1].left = Some(side(f64::INFINITY, 0.0));
    assert!(matches!(
        World::new(file),
        Err(WorldError::NotFinite { .. })
    ));
    let mut file = Params::default().file();
    file.segment_ior = Some(vec![1.0, f64::NAN, 1.0, 1.0]);
    assert!(matches!(
        World::new(file),
        Err(WorldError::NotFinite { .. })
    ));

    // Files: a missing one and a bad one are errors from from_path and run_cli.
    let missing = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/oned/no-such-file.json");
    assert!(matches!(
        World::from_path(&missing),
        Err(WorldError::Io { .. })
    ));
    let mut out = Vec::new();
    assert!(print_oned(&missing, None, &mut out).is_err());
    let figure4 = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/oned/figure4.json");
    assert!(print_oned(&figure4, Some((0.0, 0.0, 10)), &mut out).is_err());
    assert!(print_oned(&figure4, Some((f64::NAN, 1e-9, 10)), &mut out).is_err());
}

#[test]
fn inputs_that_make_times_overflow_are_refused_by_name() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("oned-overflow");
    std::fs::create_dir_all(&dir).unwrap();
    let figure4 = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/oned/figure4.json");
    let text = std::fs::read_to_string(&figure4).unwrap();
    let error = |path: &Path, bins: Option<(f64, f64, usize)>| {
        let mut out = Vec::new();
        match print_oned(path, bins, &mut out) {
            Ok(()) => "accepted".to_string(),
            Err(e) => format!("{e:#}"),
        }
    };
    // The issue's case: an index of 1e308 between A and B gave infinite times and
    // "everything absorbed". Figure 4's segments: Z | E L | A | B |.
    let write = |name: &str, text: String| {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        path
    };
    let huge_ior = write(
        "huge-ior.json",
        text.replace(
            "\"segment_ior\": [1.0, 1.0, 1.0, 1.0]",
            "\"segment_ior\": [1.0, 1.0, 1e308, 1.0]",
        ),
    );
    let e = error(&huge_ior, None);
    assert!(
        e.contains("huge-ior.json")
            && e.contains("segment_ior[2] = 1e308 over the 15 m from interface 'A' (x_m = 10)")
            && e.contains("arrival times would overflow"),
        "{e}"
    );
    // Positions 2e300 m apart, each finite.
    let far = write("far.json", text.replace("\"x_m\": 25.0", "\"x_m\": 2e300"));
    let e = error(&far, None);
    assert!(
        e.contains("interface 'B' (x_m = 2e300) are 2e300 m apart"),
        "{e}"
    );

    // The window: every edge finite in the nanoseconds printed, edges distinct.
    let e = error(&figure4, Some((1e300, 1e-9, 10)));
    assert!(e.contains("--t0 1e300 s: times overflow"), "{e}");
    let e = error(&figure4, Some((0.0, 1e299, 100)));
    assert!(
        e.contains("--dt 1e299 s x --bins 100 from --t0 0e0 s ends the window at 1e301 s"),
        "{e}"
    );
    let e = error(&figure4, Some((1.0, 1e-20, 10)));
    assert!(
        e.contains("--dt 1e-20 s is below double precision's resolution at 1e0 s"),
        "{e}"
    );
    // 2^-49 s bins at 1 s are 8 units in the last place: distinct edges.
    assert_eq!(error(&figure4, Some((1.0, 2f64.powi(-49), 10))), "accepted");
}
