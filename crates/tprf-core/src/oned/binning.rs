//! The impulse train integrated over time bins: bin `b` covers
//! `[t0_s + b dt_s, t0_s + (b + 1) dt_s)` (seconds), its edges computed as written.

use super::Impulse;

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
}
