//! Where the images go in the central panel, without egui: the time slice large and the
//! steady and rainbow images small, either in a column beside it or in a row under it,
//! whichever lets the time slice grow larger in the space there is. Images keep the
//! film's aspect and grow with the window.

/// Sizes in points of the images of the central panel and where the small ones go.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageLayout {
    /// The small images in a row under the large one (else in a column beside it).
    pub below: bool,
    /// The large image, `(width, height)`.
    pub big: (f32, f32),
    /// Each small image, `(width, height)`.
    pub small: (f32, f32),
}

/// Share of the panel the small images may take (of its width beside, of its height
/// under).
const SMALL_SHARE: f32 = 0.3;
/// Smallest side an image is drawn at.
const MIN_SIDE: f32 = 16.0;

/// The layout of a large image and two small ones of aspect `aspect` (width / height)
/// in `avail = (width, height)`, each image with `extra` points of title and colour
/// bar above and under it and `gap` points between blocks. The large image is as large
/// as fits once the small ones have their share.
pub fn image_layout(avail: (f32, f32), aspect: f32, extra: f32, gap: f32) -> ImageLayout {
    let (w, h) = (avail.0.max(1.0), avail.1.max(1.0));
    let aspect = if aspect.is_finite() && aspect > 0.0 {
        aspect
    } else {
        1.0
    };
    let size = |width: f32| (width.max(MIN_SIDE), width.max(MIN_SIDE) / aspect);
    // Beside: small images stacked in a column on the right.
    let side_small = (aspect * ((h - gap) / 2.0 - extra)).min(SMALL_SHARE * (w - gap));
    let side_big = (w - gap - side_small).min(aspect * (h - extra));
    // Under: small images side by side in a row below.
    let below_small = ((w - gap) / 2.0).min(aspect * (SMALL_SHARE * h - extra));
    let below_big = w.min(aspect * (h - gap - 2.0 * extra - below_small / aspect));
    if below_big > side_big {
        ImageLayout {
            below: true,
            big: size(below_big),
            small: size(below_small),
        }
    } else {
        ImageLayout {
            below: false,
            big: size(side_big),
            small: size(side_small),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Everything fits inside the panel, in either arrangement.
    fn fits(l: &ImageLayout, avail: (f32, f32), extra: f32, gap: f32) {
        let (bw, bh) = (l.big.0, l.big.1 + extra);
        let (sw, sh) = (l.small.0, l.small.1 + extra);
        let (w, h) = if l.below {
            (bw.max(2.0 * sw + gap), bh + gap + sh)
        } else {
            (bw + gap + sw, bh.max(2.0 * sh + gap))
        };
        assert!(
            w <= avail.0 + 0.01 && h <= avail.1 + 0.01,
            "{l:?} in {avail:?}"
        );
    }

    #[test]
    fn images_fill_the_panel_the_way_it_is_shaped() {
        let (extra, gap) = (60.0, 8.0);
        // A wide panel: the column beside.
        let wide = (1200.0, 800.0);
        let l = image_layout(wide, 1.0, extra, gap);
        assert!(!l.below);
        fits(&l, wide, extra, gap);
        // The large image takes the full height there.
        assert!((l.big.1 - (800.0 - extra)).abs() < 0.01, "{l:?}");
        // A narrow, tall panel: the row under.
        let tall = (500.0, 900.0);
        let l = image_layout(tall, 1.0, extra, gap);
        assert!(l.below);
        fits(&l, tall, extra, gap);
        assert!((l.big.0 - 500.0).abs() < 0.01, "{l:?}");
        // Images grow with the window.
        let small = image_layout((640.0, 600.0), 1.0, extra, gap);
        let large = image_layout((1000.0, 850.0), 1.0, extra, gap);
        assert!(large.big.0 > small.big.0 && large.small.0 >= small.small.0);
        fits(&small, (640.0, 600.0), extra, gap);
        // A wide film keeps its aspect.
        let l = image_layout((900.0, 700.0), 2.0, extra, gap);
        assert!((l.big.0 / l.big.1 - 2.0).abs() < 1e-4);
        fits(&l, (900.0, 700.0), extra, gap);
        // Absurd input: no panic, still a drawable size.
        let l = image_layout((0.0, f32::NAN), f32::NAN, extra, gap);
        assert!(l.big.0 >= MIN_SIDE && l.small.0 >= MIN_SIDE);
    }
}
