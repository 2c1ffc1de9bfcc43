//! Textures rebuilt only when what they were made from changes. A film image is keyed on
//! the snapshot's [`FilmSnapshot::generation`], never on its address: once a snapshot is
//! freed the allocator may hand its address to the next one, whose image would then be
//! taken for the old one's.

use super::colormap::{ColorMap, ExposureMode};
use super::settings::ViewerSettings;
use super::tone::View;
use eframe::egui::{self, TextureHandle, TextureOptions};
use tprf_core::film::FilmSnapshot;

/// Textures by name, each with the key it was made from.
pub(super) struct TextureCache<K> {
    entries: Vec<(&'static str, K, TextureHandle)>,
}

impl<K> Default for TextureCache<K> {
    fn default() -> Self {
        TextureCache {
            entries: Vec::new(),
        }
    }
}

impl<K: PartialEq> TextureCache<K> {
    /// The texture `name`: the cached one when it was made from `key`, else `make()`
    /// uploaded in its place (nearest-neighbour sampling: film pixels stay square).
    pub(super) fn get(
        &mut self,
        ctx: &egui::Context,
        name: &'static str,
        key: K,
        make: impl FnOnce() -> egui::ColorImage,
    ) -> TextureHandle {
        match self.entries.iter_mut().find(|(n, _, _)| *n == name) {
            Some((_, k, t)) => {
                if *k != key {
                    t.set(make(), TextureOptions::NEAREST);
                    *k = key;
                }
                t.clone()
            }
            None => {
                let t = ctx.load_texture(name, make(), TextureOptions::NEAREST);
                self.entries.push((name, key, t.clone()));
                t
            }
        }
    }
}

/// What an image of the film was made from (see [`super::tone::view_pixels`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct ImageKey {
    generation: u64,
    /// The time slice's bin; `None` for the images of the whole film.
    bin: Option<usize>,
    ev: f32,
    log: bool,
    exposure: ExposureMode,
    colormap: ColorMap,
}

impl ImageKey {
    /// The key of `view` of `snap` at the scrubber's `bin` with `settings`.
    pub(super) fn new(
        view: View,
        snap: &FilmSnapshot,
        bin: usize,
        settings: &ViewerSettings,
    ) -> ImageKey {
        ImageKey {
            generation: snap.generation(),
            bin: (view == View::Slice).then_some(bin),
            ev: settings.ev,
            log: settings.log_image,
            exposure: settings.exposure,
            colormap: settings.colormap,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;
    use tprf_core::film::{FilmLayout, TimeAxis};

    fn snapshot(value: f32) -> FilmSnapshot {
        let layout = FilmLayout {
            width: 3,
            height: 2,
            axis: TimeAxis::new(0.0, 1e-9, 5).unwrap(),
            bounces_separate: 0,
        };
        FilmSnapshot::from_dense(layout, 1, 1, &[value; 30], &[], None)
    }

    /// A snapshot freed and another made at its address: the image is made again.
    #[test]
    fn a_new_snapshot_at_a_reused_address_is_drawn_anew() {
        let ctx = egui::Context::default();
        let settings = ViewerSettings::default();
        let mut cache = TextureCache::default();
        let image = |snap: &FilmSnapshot| {
            egui::ColorImage::from_rgba_unmultiplied(
                [snap.width(), snap.height()],
                &super::super::tone::view_pixels(View::Slice, snap, 2, &settings).0,
            )
        };
        let a = Arc::new(snapshot(1.0));
        let addr = Arc::as_ptr(&a);
        let key_a = ImageKey::new(View::Slice, &a, 2, &settings);
        let _ = cache.get(&ctx, "slice", key_a, || image(&a));
        // The same snapshot again: cached.
        let _ = cache.get(
            &ctx,
            "slice",
            ImageKey::new(View::Slice, &a, 2, &settings),
            || panic!("remade for the same snapshot"),
        );
        drop(a);
        let b_value = snapshot(2.0);
        let mut tries = Vec::new();
        let b = loop {
            let b = Arc::new(b_value.clone());
            if Arc::as_ptr(&b) == addr || tries.len() >= 10_000 {
                break b;
            }
            tries.push(b);
        };
        if Arc::as_ptr(&b) != addr {
            eprintln!("the allocator did not reuse the address; keys compared only");
        }
        let key_b = ImageKey::new(View::Slice, &b, 2, &settings);
        assert_ne!(key_a, key_b, "a new snapshot has a new key");
        let mut made = false;
        let _ = cache.get(&ctx, "slice", key_b, || {
            made = true;
            image(&b)
        });
        assert!(made, "the new snapshot's image was taken from the cache");
    }
}
