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

mod binning;
mod engine;
mod world;

pub use binning::{bin_index, binned, binned_by_order};
pub use engine::{EnergyBudget, Impulse, ImpulseOptions, ImpulseTrain};
pub use world::{
    Direction, Interface, InterfaceKind, InterfaceSpec, Side, World, WorldError, WorldFile,
};
