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

/// `image` fitted to a GPU texture of at most `max_side` texels a side: wgpu refuses,
/// with a panic, a texture larger than the device's `max_texture_dimension_2d` or an
/// empty one. A side beyond the limit is shrunk by the smallest whole factor `k` that
/// fits, each texel the mean of a `k x k` block; an empty image becomes one transparent
/// texel. The image widget draws the texture at the film's size, so pixel picking (in
/// film pixels) is unchanged.
pub(crate) fn fit_texture(image: egui::ColorImage, max_side: usize) -> egui::ColorImage {
    let [w, h] = image.size;
    if w == 0 || h == 0 || image.pixels.len() != w * h {
        return egui::ColorImage::filled([1, 1], egui::Color32::TRANSPARENT);
    }
    let max_side = max_side.max(1);
    let k = w.div_ceil(max_side).max(h.div_ceil(max_side));
    if k <= 1 {
        return image;
    }
    let (nw, nh) = (w.div_ceil(k), h.div_ceil(k));
    let mut pixels = Vec::with_capacity(nw * nh);
    for by in 0..nh {
        for bx in 0..nw {
            let (mut sum, mut n) = ([0u32; 4], 0u32);
            for y in by * k..((by + 1) * k).min(h) {
                let row = image.pixels.get(y * w..(y + 1) * w).unwrap_or(&[]);
                for c in row.get(bx * k..((bx + 1) * k).min(w)).unwrap_or(&[]) {
                    for (s, v) in sum.iter_mut().zip(c.to_array()) {
                        *s += u32::from(v);
                    }
                    n += 1;
                }
            }
            let [r, g, b, a] = sum.map(|s| (s / n.max(1)) as u8);
            pixels.push(egui::Color32::from_rgba_premultiplied(r, g, b, a));
        }
    }
    egui::ColorImage::new([nw, nh], pixels)
}

/// Under an image of `w x h` film pixels: a note when its texture had to be shrunk to
/// the GPU's limit (see [`fit_texture`]), which happens exactly when a side of the
/// film exceeds it. (Not from the texture's own size: the steady and rainbow images
/// keep the last film's picture for a frame or two after a restart at another size.)
pub(crate) fn shrunk_note_ui(ui: &mut egui::Ui, w: usize, h: usize) {
    let max_side = ui.ctx().input(|i| i.max_texture_side).max(1);
    if w > max_side || h > max_side {
        let k = w.div_ceil(max_side).max(h.div_ceil(max_side));
        ui.label(
            egui::RichText::new(format!(
                "{w} x {h} pixels shown as {} x {}: the GPU's largest texture is \
                 {max_side} texels a side (picking and the plots use every pixel)",
                w.div_ceil(k),
                h.div_ceil(k)
            ))
            .small()
            .color(ui.visuals().warn_fg_color),
        );
    }
}

impl<K: Clone> TextureCache<K> {
    /// The texture `name` as cached, with the key it was made from.
    pub(super) fn cached(&self, name: &str) -> Option<(K, TextureHandle)> {
        self.entries
            .iter()
            .find(|(n, _, _)| *n == name)
            .map(|(_, k, t)| (k.clone(), t.clone()))
    }
}

impl<K: PartialEq> TextureCache<K> {
    /// The texture `name`: the cached one when it was made from `key`, else `make()`
    /// uploaded in its place (nearest-neighbour sampling: film pixels stay square),
    /// fitted to the GPU's largest texture ([`fit_texture`]); remade when that limit
    /// turns out smaller than the cached texture.
    pub(super) fn get(
        &mut self,
        ctx: &egui::Context,
        name: &'static str,
        key: K,
        make: impl FnOnce() -> egui::ColorImage,
    ) -> TextureHandle {
        let max_side = ctx.input(|i| i.max_texture_side);
        let make = || fit_texture(make(), max_side);
        match self.entries.iter_mut().find(|(n, _, _)| *n == name) {
            Some((_, k, t)) => {
                // A texture made before the device's limit was known may exceed it.
                if *k != key || t.size().into_iter().any(|side| side > max_side) {
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
    /// The snapshot the image was made from.
    pub(super) fn generation(&self) -> u64 {
        self.generation
    }

    /// This key with `other`'s snapshot generation.
    pub(super) fn with_generation(&self, other: &ImageKey) -> ImageKey {
        ImageKey {
            generation: other.generation,
            ..*self
        }
    }

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
            luminescence: false,
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
                &super::super::tone::view_pixels(
                    View::Slice,
                    snap,
                    2,
                    &settings,
                    &mut Default::default(),
                )
                .0,
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
