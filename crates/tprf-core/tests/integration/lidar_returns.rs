//! A LiDAR's returns on a rendered mixed pixel: one pixel sees a near ledge over half
//! its footprint and the floor under the rest, so its waveform holds two returns at
//! depths fixed by the geometry.

use crate::common::*;
use glam::Vec3;
use tprf_core::film::TimeAxis;
use tprf_core::reference::plane::Plane;
use tprf_core::sensor::{Echo, Exposure, LightPulse, Returns, Sensor, SensorModel, TimeOrigin};
use tprf_core::units::C_M_PER_S;

/// The camera and a point light 5 m above a floor (a 20 degree single pixel looking
/// straight down); a ledge 2 m below the camera covers x < 0, half the pixel. The
/// returns, from a delta pulse through 0.5 ns gates: the ledge's at `c t / 2 = 2 m`
/// (up to 2 / cos 10 deg = 2.03 m at the footprint's edge) and the floor's at 5 to
/// 5.08 m, within half a gate (7.5 cm); the ledge's is the strongest (its radiance goes
/// as 1 / r^2 from the light: 2.5^2 = 6.25 times the floor's, over the same share of
/// the pixel) and the floor's the last.
#[test]
fn a_mixed_pixel_gives_both_depths() {
    let mut scene = Plane::colocated(5.0, 0.5, 1.0, 10.0, 20.0).scene();
    let z = 3.0;
    let ledge = [
        Vec3::new(-5.0, -5.0, z),
        Vec3::new(0.0, -5.0, z),
        Vec3::new(0.0, 5.0, z),
        Vec3::new(-5.0, 5.0, z),
    ];
    push_tri(&mut scene, [ledge[0], ledge[1], ledge[2]], 0);
    push_tri(&mut scene, [ledge[0], ledge[2], ledge[3]], 0);
    let dt_s = 0.05e-9;
    let axis = TimeAxis::new(0.0, dt_s, 800).unwrap();
    let r = render_scene(scene, 1, 1, axis, 2048, 3, 0);
    let cube: Vec<f32> = r.film.cube_f64().iter().map(|&v| v as f32).collect();
    let gate_s = 0.5e-9;
    let mut sensor = Sensor::new(
        LightPulse::default(),
        Exposure::Box {
            origin: TimeOrigin::Pulse,
            start_s: 0.0,
            width_s: gate_s,
            step_s: None,
            count: 80,
            gain: 1.0,
        },
    );
    sensor.derived.returns = Some(Returns {
        threshold: 0.1,
        ..Returns::default()
    });
    let model = SensorModel::new(sensor, axis).unwrap();
    let m = model.measure(&cube, 1, 1).unwrap();
    let Some(returns) = model.returns(&m) else {
        panic!("the sensor asks for returns");
    };
    let half_gate_m = 0.5 * C_M_PER_S * gate_s / 2.0;
    let near = f64::from(returns.depth(Echo::Nth(0))[0]);
    let far = f64::from(returns.depth(Echo::Nth(1))[0]);
    assert_eq!(returns.count, vec![2], "{returns:?}");
    assert!(
        (2.0 - half_gate_m..2.03 + half_gate_m).contains(&near),
        "first return at {near} m"
    );
    assert!(
        (5.0 - half_gate_m..5.08 + half_gate_m).contains(&far),
        "second return at {far} m"
    );
    assert_eq!(
        returns.depth(Echo::Strongest)[0],
        returns.depth(Echo::First)[0]
    );
    assert_eq!(returns.depth(Echo::Last)[0], returns.depth(Echo::Nth(1))[0]);
    // Intensities: the ledge's about 6.25 times the floor's (cos^4-like falloffs over
    // the 10 degree half-angle differ by under 3 %; noise at 2048 spp a few per cent).
    let ratio = returns.intensity[0] / returns.intensity[1];
    assert!((5.5..7.0).contains(&ratio), "intensity ratio {ratio}");
}
