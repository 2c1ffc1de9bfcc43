//! Memory as a budget the film's store respects while it grows.
//!
//! A film holds a fixed part whatever light it stores ([`FilmLayout::fixed_bytes`]),
//! and a store that grows with the bins that receive light. Before every pass the
//! session foresees what the film will hold at the pass's end and while it runs, and
//! stops at the last whole pass when that would exceed the budget: the request's
//! `max_memory`, or what the process may still allocate ([`crate::budget::available`]:
//! free memory, the cgroup's room, the address-space and data limits). Before the
//! first pass, a small pilot render foresees the first pass's store, and a request
//! whose first pass cannot fit is refused with the size foreseen.
//!
//! What a pass is foreseen to hold, in bytes (an estimate meant to err high, of the
//! film's own allocations, not the process's: the rate of new bins falls as the bins
//! fill, so the last pass's rate over-predicts; the pilot's rate, from one sample on
//! about a thousand pixels, is what it is, with [`SLACK`] over it):
//! - the film now: the fixed part and the store's growth so far, `G`;
//! - the pass's new bins: `s x P x r` for `s` samples per pixel on the `P` pixels
//!   rendered, `r` new bins per pixel and sample in the last pass (the pilot's bins per
//!   sample before the first; fewer new bins per sample as the bins fill, so the last
//!   pass's rate over-predicts), at most the bins still empty, each costing what a
//!   stored bin has cost so far (values, run headers, bounce layers);
//! - readers' copies: rows a published snapshot still shares are rebuilt beside it
//!   (the window's worker keeps two snapshots: `2 G`);
//! - per thread, a pass's working rows and scratch, and the Zarr writer's tile after
//!   the pass.
//!
//! The film's need is compared with `max_memory`; the film's need and the writer's
//! scratch with the heap the film holds now plus what the process may still allocate
//! (less a reserve, over a headroom): the fixed part's snapshot images, exported steady
//! image and file row, allocated only when the files are written, must fit in that room.

use super::{Problem, RequestError};
use crate::budget::{self, Limit, format_bytes};
use crate::film::{FilmLayout, TimeAxis, TprfFilm};
use crate::transport::sampler::Sampler;
use crate::transport::{Renderer, Sink};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::fmt;

/// Bytes a stored bin of the halves costs at most before the film has any: its two f64
/// sums and a run header.
const BIN_BYTES: f64 = 16.0 + 4.0;
/// Bytes a stored bin of a bounce layer costs at most: one f64 and a run header.
const LAYER_BIN_BYTES: f64 = 8.0 + 4.0;
/// What the allocator may hand out beyond what is asked for (vectors grow by doubling
/// and are shrunk after a merge; this margin covers what is left).
const SLACK: f64 = 1.25;
/// Memory kept free beside the film when the limit is the system's (what the rest of
/// the process needs: its threads' stacks, the files being written).
const RESERVE_BYTES: u64 = 64 << 20;
/// What the room the system leaves is divided by before a pass is foreseen to fit in it
/// (`max_memory`, a budget for the film's own bytes, is compared as it is).
const SYSTEM_HEADROOM: f64 = 1.25;
/// Pixels of the pilot that foresees the first pass.
const PILOT_PIXELS: usize = 1024;

/// What limited the memory a render stopped at.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MemoryLimit {
    /// The request's `max_memory`.
    MaxMemory,
    /// Free system memory.
    System,
    /// A cgroup's memory limit.
    Cgroup,
    /// The address-space limit (`ulimit -v`).
    AddressSpace,
    /// The data limit (`ulimit -d`).
    DataSegment,
}

impl MemoryLimit {
    fn from_budget(limit: Limit) -> MemoryLimit {
        match limit {
            Limit::System => MemoryLimit::System,
            Limit::CgroupV2 | Limit::CgroupV1 => MemoryLimit::Cgroup,
            Limit::AddressSpace => MemoryLimit::AddressSpace,
            Limit::DataSegment => MemoryLimit::DataSegment,
        }
    }

    /// The name `tprf.json` records (`max_memory`, `system`, `cgroup`, `address_space`,
    /// `data_segment`).
    pub fn key(self) -> &'static str {
        match self {
            MemoryLimit::MaxMemory => "max_memory",
            MemoryLimit::System => "system",
            MemoryLimit::Cgroup => "cgroup",
            MemoryLimit::AddressSpace => "address_space",
            MemoryLimit::DataSegment => "data_segment",
        }
    }

    /// What a need went over, in words: `max_memory (2.0 GiB)`, or, for the system's
    /// limits, the part of the room they leave that the film may take (a part is kept
    /// for the rest of the process).
    fn over(self, limit_bytes: u64, name: impl Fn(&str) -> String) -> String {
        let limit = self.describe().text_with(name);
        match self {
            MemoryLimit::MaxMemory => format!("{limit} ({})", format_bytes(limit_bytes)),
            _ => format!(
                "the {} that {limit} leaves the film",
                format_bytes(limit_bytes)
            ),
        }
    }

    fn describe(self) -> Problem {
        match self {
            MemoryLimit::MaxMemory => Problem::field("max_memory"),
            MemoryLimit::System => Problem::text_only("free system memory"),
            MemoryLimit::Cgroup => Problem::text_only("the cgroup's memory limit"),
            MemoryLimit::AddressSpace => Problem::text_only("the address-space limit (ulimit -v)"),
            MemoryLimit::DataSegment => Problem::text_only("the data limit (ulimit -d)"),
        }
    }
}

/// Why a render stopped before its target: its next pass would not fit in memory. The
/// film holds the passes before it, whole.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MemoryStop {
    /// Samples per pixel in the film when it stopped.
    pub spp: u64,
    /// Passes made.
    pub passes: u64,
    /// Samples per pixel the next pass would have added.
    pub next_pass_spp: u32,
    /// Bytes the film was foreseen to need during the next pass.
    pub need_bytes: u64,
    /// Bytes it may use: `max_memory`, or what it holds now plus what the process may
    /// still allocate (less a reserve).
    pub limit_bytes: u64,
    pub limited_by: MemoryLimit,
}

impl MemoryStop {
    /// The message, the limit named by `name` (the command line's `--max-memory`).
    pub fn text_with(&self, name: impl Fn(&str) -> String) -> String {
        format!(
            "stopped at {} spp after {} passes: the next pass ({} more spp) would take the \
             film to {}, over {}; the output holds the passes made",
            self.spp,
            self.passes,
            self.next_pass_spp,
            format_bytes(self.need_bytes),
            self.limited_by.over(self.limit_bytes, &name),
        )
    }
}

impl fmt::Display for MemoryStop {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text_with(str::to_string))
    }
}

/// A request whose first pass cannot fit: the film foreseen by the pilot render.
#[derive(Clone, Debug, PartialEq)]
pub struct MemoryRefusal {
    pub width: usize,
    pub height: usize,
    pub bins: usize,
    /// Bins of the halves a pixel's sample stored in the pilot render, on average.
    pub bins_per_sample: f64,
    /// Bytes foreseen for the film during its first pass (fixed part included).
    pub need_bytes: u64,
    pub limit_bytes: u64,
    pub limited_by: MemoryLimit,
}

impl MemoryRefusal {
    /// The message, the limit named by `name`.
    pub fn text_with(&self, name: impl Fn(&str) -> String) -> String {
        format!(
            "a film of {} x {} pixels x {} bins would need about {} in its first pass \
             ({:.1} bins stored per pixel and sample in a pilot render), over {}: lower \
             the resolution or the bins{}",
            self.width,
            self.height,
            self.bins,
            format_bytes(self.need_bytes),
            self.bins_per_sample,
            self.limited_by.over(self.limit_bytes, &name),
            match self.limited_by {
                MemoryLimit::MaxMemory => format!(", or raise {}", name("max_memory")),
                _ => String::new(),
            }
        )
    }
}

impl fmt::Display for MemoryRefusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text_with(str::to_string))
    }
}

/// The film's memory budget and what it has seen of the film's growth.
#[derive(Clone, Debug)]
pub(super) struct MemoryBudget {
    max_bytes: Option<u64>,
    /// Snapshot generations readers keep beside the film (the window's worker: 2).
    reader_copies: u64,
    /// Threads a pass runs on.
    threads: u64,
    /// The store's bytes while empty.
    empty_store_bytes: u64,
    /// New bins of the halves per pixel and sample, last seen (the pilot's at first).
    bins_per_sample: f64,
    /// Bytes a stored bin of the halves costs (the layers' bins and run headers
    /// included), last seen (foreseen from the pilot at first).
    bytes_per_bin: f64,
    /// Bins stored before the pass now running, and its samples per pixel.
    before_pass: Option<(u64, u32)>,
}

/// What a pass is foreseen to need, bytes.
struct Foreseen {
    /// The film during the pass (its whole fixed part included).
    film: u64,
    /// The writer's scratch after it, beyond the film.
    writer: u64,
}

/// Bins of the halves and of the bounce layers one sample of a pixel touches.
struct CountingSink {
    axis: TimeAxis,
    tent: bool,
    /// The film's layout, for the layer a contribution lands in.
    layout: FilmLayout,
    bins: Vec<usize>,
    layer_bins: Vec<(usize, usize)>,
}

impl Sink for CountingSink {
    fn add(&mut self, arrival_s: f64, value: f64, scatterings: u32) {
        if !(value.is_finite() && value != 0.0) {
            return;
        }
        let Some(b) = self.axis.bin_of(arrival_s) else {
            return;
        };
        let mut push = |bin: usize| {
            self.bins.push(bin);
            if self.layout.bounce_layers() > 0 {
                self.layer_bins
                    .push((self.layout.layer_of(scatterings), bin));
            }
        };
        push(b);
        // A tent spreads a contribution over its bin and a neighbour.
        if self.tent {
            if b > 0 {
                push(b - 1);
            }
            if b + 1 < self.axis.bins {
                push(b + 1);
            }
        }
    }

    fn window_end_s(&self) -> f64 {
        self.axis.end_s()
    }

    fn window_start_s(&self) -> f64 {
        self.axis.t0_s
    }
}

impl MemoryBudget {
    /// A budget of `max_bytes` (`None`: what the process may allocate) for `film`,
    /// whose first pass is foreseen by a pilot render of about [`PILOT_PIXELS`] of its
    /// pixels at one sample each (seeded: the same estimate every time).
    pub fn new(
        max_bytes: Option<u64>,
        renderer: &Renderer,
        film: &TprfFilm,
        tent: bool,
    ) -> MemoryBudget {
        let layout = *film.layout();
        let (w, h) = (layout.width, layout.height);
        let step = ((w * h) as f64 / PILOT_PIXELS as f64).sqrt().max(1.0);
        let (pw, ph) = (
            ((w as f64 / step).ceil() as usize).max(1),
            ((h as f64 / step).ceil() as usize).max(1),
        );
        let seed = renderer.settings().seed ^ 0x4d45_4d4f_5259_0000;
        let counts: Vec<(usize, usize)> = (0..pw * ph)
            .into_par_iter()
            .map(|i| {
                let x = (((i % pw) as f64 + 0.5) * step) as usize;
                let y = (((i / pw) as f64 + 0.5) * step) as usize;
                let (x, y) = (x.min(w - 1), y.min(h - 1));
                let mut sink = CountingSink {
                    axis: layout.axis,
                    tent,
                    layout,
                    bins: Vec::new(),
                    layer_bins: Vec::new(),
                };
                let mut rng = Sampler::new(seed, 0, (y * w + x) as u64);
                renderer.trace_sample(x, y, w, h, &mut rng, &mut sink);
                sink.bins.sort_unstable();
                sink.bins.dedup();
                sink.layer_bins.sort_unstable();
                sink.layer_bins.dedup();
                (sink.bins.len(), sink.layer_bins.len())
            })
            .collect();
        let n = counts.len().max(1) as f64;
        let bins_per_sample = counts.iter().map(|c| c.0 as f64).sum::<f64>() / n;
        let layer_bins = counts.iter().map(|c| c.1 as f64).sum::<f64>() / n;
        let bytes_per_bin = SLACK
            * (BIN_BYTES
                + if bins_per_sample > 0.0 {
                    LAYER_BIN_BYTES * layer_bins / bins_per_sample
                } else {
                    0.0
                });
        MemoryBudget {
            max_bytes,
            reader_copies: 0,
            threads: rayon::current_num_threads() as u64,
            empty_store_bytes: film.store_stats().bytes,
            bins_per_sample,
            bytes_per_bin,
            before_pass: None,
        }
    }

    /// Readers keep `copies` snapshots beside the film while it renders.
    pub fn set_reader_copies(&mut self, copies: u64) {
        self.reader_copies = copies;
    }

    pub fn bins_per_sample(&self) -> f64 {
        self.bins_per_sample
    }

    /// Bytes `film` is foreseen to need while a pass of `spp` samples per pixel runs and
    /// while its files are written after it (with the whole fixed part: the parts a
    /// snapshot and the writer allocate only then included).
    fn foresee(&self, film: &TprfFilm, spp: u32) -> Foreseen {
        let layout: FilmLayout = *film.layout();
        let fixed = layout.fixed_bytes().unwrap_or(u64::MAX);
        let stats = film.store_stats();
        let grown = stats.bytes.saturating_sub(self.empty_store_bytes);
        let pixels = (layout.width * film.rows_rendered()) as f64;
        let dense = pixels * layout.axis.bins as f64;
        let empty_bins = (dense - stats.stored_bins as f64).max(0.0);
        let new_bins = (spp as f64 * pixels * self.bins_per_sample).min(empty_bins);
        let new_bytes = new_bins * self.bytes_per_bin;
        // Per thread: a row being rebuilt beside the old one, the pass's scratch (an
        // axis of f64 for the halves and each layer, a bitmap) and its buffer of new bins
        // (room for 32 a pixel).
        let rows = film.rows_rendered().max(1) as f64;
        let row_bytes = (grown as f64 + new_bytes) / rows;
        let layers = layout.bounce_layers() as f64;
        let scratch = layout.axis.bins as f64 * 8.0 * (2.0 + layers + 1.0)
            + layout.width as f64 * 32.0 * 16.0;
        let per_thread = 2.0 * row_bytes + scratch;
        // The Zarr writer, per thread, after the pass: a 32 x 32 tile's values (f32, in a
        // vector that may have doubled; four times the mean pixel's bins, at most the
        // tile's dense size), a decoded chunk and its compressed copy. (The `.npy`
        // writer's dense row is in the fixed part.)
        let bins_after = (stats.stored_bins as f64 + new_bins) / pixels.max(1.0);
        let tile_values = (4.0 * bins_after).min(layout.axis.bins as f64) * 1024.0;
        let writer = 2.0 * 4.0 * tile_values + 2.0 * crate::export::zarr::CHUNK_BYTES as f64;
        let during = grown as f64 * (1 + self.reader_copies) as f64
            + new_bytes
            + self.threads as f64 * per_thread;
        let bytes = |b: f64| b.min(u64::MAX as f64) as u64;
        Foreseen {
            film: bytes(fixed as f64 + during),
            writer: bytes(self.threads as f64 * writer),
        }
    }

    /// Whether a pass of `spp` samples per pixel fits: `Err` with what it would need and
    /// the limit it would pass, else the samples per pixel of the pass to make, its start
    /// noted (for the next rate). With `shrink`, a pass that does not fit is made as
    /// large as fits (the need grows with the samples), and `Err` only when one sample
    /// per pixel does not. What the pass before it added (noted then) sets the rate
    /// first.
    pub fn before_pass(
        &mut self,
        film: &TprfFilm,
        spp: u32,
        shrink: bool,
    ) -> Result<u32, (u64, u64, MemoryLimit)> {
        self.after_pass(film);
        let system = self.system_limit(film);
        // `max_memory` bounds the film; what the system leaves bounds the process: the
        // film and the writer's scratch after the pass.
        let fits = |s: u32| {
            let f = self.foresee(film, s);
            if let Some(max) = self.max_bytes
                && f.film > max
            {
                return Err((f.film, max, MemoryLimit::MaxMemory));
            }
            let need = f.film.saturating_add(f.writer);
            match system {
                Some((limit, by)) if need > limit => Err((need, limit, by)),
                _ => Ok(()),
            }
        };
        let pass_spp = match fits(spp) {
            Ok(()) => spp,
            Err(over) if !shrink || spp <= 1 => return Err(over),
            Err(_) => {
                // The largest pass that fits, in [1, spp): `lo` fits or is 0.
                let (mut lo, mut hi) = (0u32, spp);
                while hi - lo > 1 {
                    let mid = lo + (hi - lo) / 2;
                    if fits(mid).is_ok() {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                if lo == 0 {
                    fits(1)?;
                }
                lo.max(1)
            }
        };
        self.before_pass = Some((film.store_stats().stored_bins, pass_spp));
        Ok(pass_spp)
    }

    /// The bytes the process may give the film and its writer, and what sets them: what
    /// the film holds plus what the process may still allocate, less a reserve for the
    /// rest of the process and a headroom (`None`: no limit known).
    fn system_limit(&self, film: &TprfFilm) -> Option<(u64, MemoryLimit)> {
        budget::available().map(|a| {
            // A part of the room is kept for what the estimate does not see: the
            // allocator's reservations and fragmentation, address space the threads
            // reserve (a first pass of 4096 x 4096 x 65536 bins under `ulimit -v`
            // foreseen at 3.4 GiB took 3.7 GiB).
            let room =
                a.bytes.saturating_sub(RESERVE_BYTES.min(a.bytes / 10)) as f64 / SYSTEM_HEADROOM;
            // What the film holds now: its rows' heap, a row shared by several rows or
            // by a snapshot counted once (a new film's rows are one empty row: counting
            // it per row let a 4096 x 4096 first pass through that then outgrew
            // `ulimit -v`). The rest of the fixed part (each row made its own, the
            // snapshot images, exported steady image and file row) is not allocated yet,
            // so the room left must cover it.
            let held = film.held_bytes();
            (
                held.saturating_add(room as u64),
                MemoryLimit::from_budget(a.limited_by),
            )
        })
    }

    /// After a pass: the rate of new bins and their cost, as seen.
    fn after_pass(&mut self, film: &TprfFilm) {
        let Some((before, spp)) = self.before_pass.take() else {
            return;
        };
        let stats = film.store_stats();
        let pixels = (film.layout().width * film.rows_rendered()) as f64;
        if pixels > 0.0 && spp > 0 {
            let added = stats.stored_bins.saturating_sub(before) as f64;
            self.bins_per_sample = added / (pixels * spp as f64);
        }
        if stats.stored_bins > 0 {
            let grown = stats.bytes.saturating_sub(self.empty_store_bytes) as f64;
            self.bytes_per_bin = SLACK * grown / stats.stored_bins as f64;
        }
    }

    /// Refuse a first pass of `spp` that cannot fit.
    pub fn check_first_pass(&mut self, film: &TprfFilm, spp: u32) -> Result<(), RequestError> {
        match self.before_pass(film, spp, false) {
            Ok(_) => {
                self.before_pass = None;
                Ok(())
            }
            Err((need_bytes, limit_bytes, limited_by)) => {
                let l = film.layout();
                Err(RequestError::Memory(MemoryRefusal {
                    width: l.width,
                    height: l.height,
                    bins: l.axis.bins,
                    bins_per_sample: self.bins_per_sample,
                    need_bytes,
                    limit_bytes,
                    limited_by,
                }))
            }
        }
    }
}
