//! The phasor tab: a frequency's amplitude and phase images, from the cube's
//! `phasor.npy` (a folder written with `--phasor` or from a `phasor_hdr_film` file) or
//! computed from the film at mitransient's frequencies of a band
//! (`tprf_core::export::phasor`).
//!
//! - [`maths`]: the planes, their white point, the cyclic phase colours, a frequency in
//!   words (tested without a window);
//! - `view`: the central panel, a function over a narrow context (`PhasorState`, the
//!   phasors' source, the band and the frequency chosen).

pub mod maths;
mod view;

pub(crate) use view::{PhasorInput, PhasorState, phasor_ui};
