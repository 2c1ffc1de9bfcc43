//! A polarized render's film: the Stokes parameters S0..S3 (docs/polarization.md) as
//! four [`TprfFilm`]s of one layout passed in lockstep. S0 is the ordinary film (the
//! intensity: every reader, error estimate and adaptive plan works on it unchanged); S1,
//! S2 and S3 are films like it whose bins may be negative (the sparse runs keep any
//! non-zero value; their peaks and error terms are not read: a pass's plan and a
//! render's error are S0's).
//!
//! A pass renders each pixel's samples once, into four sinks ([`StokesPixelSink`]), and
//! adds each sink's bins to its film's row: the films stay in lockstep (same passes,
//! halves, samples per pixel and rows rendered).

use super::row::{PixelPass, RowTally, RowWork, commit_row, drawn_after, pixel_pass};
use super::store::leaf_rows;
use super::{FilmError, PassTally, PixelSink, TprfFilm};
use rayon::prelude::*;

/// The films of S1, S2 and S3 beside an S0 film (see the module's notes).
#[derive(Clone, Debug)]
pub struct StokesFilms {
    /// S1, S2, S3, in that order.
    s123: [TprfFilm; 3],
}

/// Where one pixel's Stokes contributions of one pass go: a sink per component,
/// `sinks[k]` for `S_k`.
pub struct StokesPixelSink<'a> {
    pub sinks: [PixelSink<'a>; 4],
}

impl StokesFilms {
    /// Empty S1..S3 films like `s0` (its layout, time filter and rows rendered), which
    /// must be empty too.
    pub fn like(s0: &TprfFilm) -> Result<StokesFilms, FilmError> {
        let one = || -> Result<TprfFilm, FilmError> {
            let mut f = TprfFilm::new(*s0.layout())?.with_time_filter(s0.time_filter());
            f.rows_rendered = s0.rows_rendered.clone();
            Ok(f)
        };
        Ok(StokesFilms {
            s123: [one()?, one()?, one()?],
        })
    }

    /// The film of `S_k`, `k` in 1..=3 (`None` otherwise: S0 is the caller's film).
    pub fn component(&self, k: usize) -> Option<&TprfFilm> {
        self.s123.get(k.checked_sub(1)?)
    }

    /// One pass into `s0` and these films, as [`TprfFilm::run_pass_planned`] into `s0`
    /// alone: `render_pixel(x, y, pass, sink)` draws the pixel's samples into the four
    /// sinks. The tally is S0's (what arrived outside the window, work left out), with
    /// the non-finite contributions of every component counted.
    pub fn run_pass_planned<F>(
        &mut self,
        s0: &mut TprfFilm,
        spp_in_pass: u32,
        plan: Option<&[u32]>,
        render_pixel: F,
    ) -> PassTally
    where
        F: Fn(usize, usize, PixelPass, &mut StokesPixelSink<'_>) -> u64 + Sync,
    {
        let layout = *s0.layout();
        let half = (s0.passes % 2) as usize;
        let filter = s0.time_filter();
        let mut spp_after = s0.spp;
        spp_after[half] += spp_in_pass as u64;
        let w = layout.width;
        let plan = plan.filter(|p| p.len() == layout.pixels());
        let rows_rendered = s0.rows_rendered.clone();
        let [f1, f2, f3] = &mut self.s123;
        let tallies: Vec<RowTally> = s0
            .rows
            .par_iter_mut()
            .zip(f1.rows.par_iter_mut())
            .zip(f2.rows.par_iter_mut())
            .zip(f3.rows.par_iter_mut())
            .with_max_len(leaf_rows(&layout))
            .enumerate()
            .map_init(
                || std::array::from_fn::<_, 4, _>(|_| RowWork::new(&layout)),
                |works, (y, (((r0, r1), r2), r3))| {
                    let mut tally = RowTally::default();
                    if rows_rendered
                        .as_ref()
                        .is_some_and(|r| !r.get(y).copied().unwrap_or(false))
                    {
                        return tally;
                    }
                    let row_plan = plan.and_then(|p| p.get(y * w..(y + 1) * w));
                    for work in works.iter_mut() {
                        work.begin_row(&layout);
                    }
                    let mut samples = Vec::with_capacity(w);
                    for x in 0..w {
                        let (pass, weight) = pixel_pass(r0, x, half, spp_in_pass, row_plan);
                        let [w0, w1, w2, w3] = &mut *works;
                        let mut sink = StokesPixelSink {
                            sinks: [w0, w1, w2, w3]
                                .map(|wk| PixelSink::new(layout, filter, weight, wk.scratch())),
                        };
                        let cost = render_pixel(x, y, pass, &mut sink);
                        let [k0, rest @ ..] = &sink.sinks;
                        tally.work += cost;
                        tally.outside += k0.outside;
                        tally.left_out += k0.left_out;
                        tally.left_out.non_finite +=
                            rest.iter().map(|k| k.left_out.non_finite).sum::<u64>();
                        samples.push(drawn_after(r0, x, half, pass, cost));
                        for work in works.iter_mut() {
                            work.end_pixel(&layout);
                        }
                    }
                    let [w0, w1, w2, w3] = &mut *works;
                    commit_row(r1, &layout, half, spp_after, w1, samples.clone());
                    commit_row(r2, &layout, half, spp_after, w2, samples.clone());
                    commit_row(r3, &layout, half, spp_after, w3, samples.clone());
                    commit_row(r0, &layout, half, spp_after, w0, samples);
                    tally
                },
            )
            .collect();
        let tally = PassTally::of_rows(tallies, layout.width * s0.rows_rendered());
        for f in [&mut *s0, f1, f2, f3] {
            f.spp = spp_after;
            f.passes += 1;
        }
        tally
    }
}
