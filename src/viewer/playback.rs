//! The scrubber's bin over time: stepping (wrapping or stopping at the ends), the arrow
//! and space keys, and the playback clock that advances `play_bins_per_s` bins a second.

use super::app::TprfApp;
use super::settings::Mode;
use eframe::egui;

/// Bin `bin + delta` of `bins` (`bins > 0`): wrapped round when `looping`, else held at
/// the first or last bin.
fn stepped_bin(bin: usize, delta: i64, bins: usize, looping: bool) -> usize {
    let b = bin as i64 + delta;
    if looping {
        b.rem_euclid(bins as i64) as usize
    } else {
        b.clamp(0, bins as i64 - 1) as usize
    }
}

impl TprfApp {
    /// A time plot (x in ns after the pulse on `axis`) dragged or clicked at `pointer`:
    /// the scrubber goes to the bin under it and playback stops.
    pub(crate) fn scrub_from_plot(
        &mut self,
        response: &egui::Response,
        pointer: Option<egui_plot::PlotPoint>,
        axis: &tprf_core::film::TimeAxis,
    ) {
        if (response.dragged() || response.clicked())
            && let Some(p) = pointer
        {
            let b = ((p.x * 1e-9 - axis.t0_s) / axis.dt_s).floor();
            if b.is_finite() {
                self.bin = (b.max(0.0) as usize).min(axis.bins.saturating_sub(1));
                self.playing = false;
            }
        }
    }

    /// Move the scrubber `delta` bins in a window of `bins` (nothing when there are none).
    pub(super) fn step(&mut self, delta: i64, bins: usize) {
        if bins > 0 {
            self.bin = stepped_bin(self.bin, delta, bins, self.settings.looping);
        }
    }

    /// Arrows step a bin (the gate shown, in sensor mode) and pause; space plays or
    /// pauses. Keys typed into a text field are left to it.
    pub(super) fn handle_keys(&mut self, ctx: &egui::Context, bins: usize) {
        if ctx.egui_wants_keyboard_input() {
            return;
        }
        // Counted, not tested: presses quicker than the frames each step once.
        let (left, right, space) = ctx.input(|i| {
            (
                i.num_presses(egui::Key::ArrowLeft),
                i.num_presses(egui::Key::ArrowRight),
                i.key_pressed(egui::Key::Space),
            )
        });
        if self.settings.mode == Mode::Sensor {
            // In sensor mode the arrows step the gate shown.
            let gates = self.sensor.model().map_or(1, |m| m.gate_count());
            self.sensor.gate =
                (self.sensor.gate.saturating_sub(left) + right).min(gates.saturating_sub(1));
            return;
        }
        if self.settings.mode == Mode::Phasor {
            // In the phasor tab the arrows step the frequency (the tab clamps it).
            let j = &mut self.settings.phasor_index;
            *j = j.saturating_sub(left).saturating_add(right);
            return;
        }
        self.bin_keys(left, right, space, bins);
    }

    /// The scrubber's keys: each press of an arrow steps a bin and pauses (`left` and
    /// `right` count this frame's presses), space plays or pauses.
    pub(super) fn bin_keys(&mut self, left: usize, right: usize, space: bool, bins: usize) {
        for _ in 0..left {
            self.playing = false;
            self.step(-1, bins);
        }
        for _ in 0..right {
            self.playing = false;
            self.step(1, bins);
        }
        if space {
            self.playing = !self.playing;
        }
    }

    /// While playing, advance by `play_bins_per_s` times the time since the last frame
    /// that played (at most 0.1 s a frame; the first frame of a playback counts one
    /// predicted frame), whole bins at a time; without looping, stop at the last bin.
    /// Asks for the frame where the next bin is due, not the next frame: frames between
    /// would show the same picture (at the default 30 bins a second, every other frame
    /// of a 60 Hz display).
    pub(super) fn advance_playback(&mut self, ctx: &egui::Context, bins: usize) {
        let (now_s, predicted_s) = ctx.input(|i| (i.time, i.predicted_dt));
        let last_s = self.play_time_s.take();
        if !self.playing || bins == 0 {
            return;
        }
        self.play_time_s = Some(now_s);
        // Up to half a second of play per frame: a slow frame skips bins rather than
        // slowing the light down.
        let dt = last_s
            .map_or(predicted_s, |t| (now_s - t) as f32)
            .clamp(0.0, 0.5);
        let rate = match self.settings.play_bins_per_s {
            r if r.is_finite() && r > 0.0 => r,
            _ => 30.0,
        };
        self.play_accum += dt * rate;
        let steps = self.play_accum.floor();
        if steps >= 1.0 {
            self.play_accum -= steps;
            let before = self.bin;
            self.step(steps as i64, bins);
            if !self.settings.looping && self.bin == before {
                self.playing = false;
                return;
            }
        }
        // When the accumulator reaches 1, but no sooner than the frame rate the window
        // can spare: frames are dropped, never the render's passes.
        let due_s = ((1.0 - self.play_accum) / rate).max(playback_interval_s(self.timing.cpu_ms));
        ctx.request_repaint_after(
            std::time::Duration::try_from_secs_f32(due_s).unwrap_or_default(),
        );
    }
}

/// Share of one core playback may spend drawing frames: the rest is the render's.
const PLAYBACK_CPU_SHARE: f32 = 0.25;

/// The shortest time between playback's frames, seconds, for frames costing `cpu_ms`
/// (eframe's measure of the last frame, painting included): frames take at most
/// [`PLAYBACK_CPU_SHARE`] of a core (under software rendering a frame costs tens of
/// milliseconds), and come no faster than 60 per second nor slower than 4.
pub(super) fn playback_interval_s(cpu_ms: Option<f32>) -> f32 {
    let ms = cpu_ms.filter(|m| m.is_finite() && *m > 0.0).unwrap_or(0.0);
    (ms / 1000.0 / PLAYBACK_CPU_SHARE).clamp(1.0 / 60.0, 0.25)
}

#[cfg(test)]
mod tests {
    use super::{playback_interval_s, stepped_bin};

    /// A 2 ms frame plays at 60 Hz; a 40 ms one (software rendering) every 160 ms, a
    /// quarter of a core; a 200 ms one no slower than 4 Hz.
    #[test]
    fn playback_spares_the_render_its_cores() {
        assert_eq!(playback_interval_s(Some(2.0)), 1.0 / 60.0);
        assert!((playback_interval_s(Some(40.0)) - 0.16).abs() < 1e-6);
        assert_eq!(playback_interval_s(Some(200.0)), 0.25);
        assert_eq!(playback_interval_s(None), 1.0 / 60.0);
    }

    #[test]
    fn steps_wrap_when_looping_and_stop_otherwise() {
        assert_eq!(stepped_bin(0, -1, 10, true), 9);
        assert_eq!(stepped_bin(9, 3, 10, true), 2);
        assert_eq!(stepped_bin(0, -1, 10, false), 0);
        assert_eq!(stepped_bin(8, 5, 10, false), 9);
        assert_eq!(stepped_bin(4, 1, 10, false), 5);
    }
}
