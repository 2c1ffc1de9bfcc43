//! The pixel or box the plots show: picked on an image, pinned, clamped onto a new film.

use tprf_core::film::FilmSnapshot;

/// A pixel box on the image (inclusive); one pixel when both corners agree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Selection {
    pub x0: usize,
    pub y0: usize,
    pub x1: usize,
    pub y1: usize,
}

impl Selection {
    /// The one pixel `(x, y)`.
    pub fn pixel(x: usize, y: usize) -> Selection {
        Selection {
            x0: x,
            y0: y,
            x1: x,
            y1: y,
        }
    }

    /// The same box with `x0 <= x1` and `y0 <= y1`.
    pub(super) fn normalized(self) -> Selection {
        Selection {
            x0: self.x0.min(self.x1),
            y0: self.y0.min(self.y1),
            x1: self.x0.max(self.x1),
            y1: self.y0.max(self.y1),
        }
    }

    /// The box moved inside a `w x h` image.
    pub(super) fn clamped(self, w: usize, h: usize) -> Selection {
        let (mx, my) = (w.saturating_sub(1), h.saturating_sub(1));
        Selection {
            x0: self.x0.min(mx),
            y0: self.y0.min(my),
            x1: self.x1.min(mx),
            y1: self.y1.min(my),
        }
    }

    /// The same scene point on a film of `to = (w, h)` pixels, for a selection made on a
    /// film of `from` pixels: a pixel goes to the pixel holding its centre, a box to the
    /// pixels covering it. Clamped inside the new film.
    pub fn rescaled(self, from: (usize, usize), to: (usize, usize)) -> Selection {
        let s = self.normalized();
        let (fw, fh) = (from.0.max(1) as f64, from.1.max(1) as f64);
        let (tw, th) = (to.0.max(1) as f64, to.1.max(1) as f64);
        let centre = |p: usize, f: f64, t: f64| ((p as f64 + 0.5) * t / f).floor() as usize;
        let out = if s.x0 == s.x1 && s.y0 == s.y1 {
            Selection::pixel(centre(s.x0, fw, tw), centre(s.y0, fh, th))
        } else {
            let lo = |p: usize, f: f64, t: f64| (p as f64 * t / f + 1e-9).floor() as usize;
            let hi = |p: usize, f: f64, t: f64| {
                (((p + 1) as f64 * t / f - 1e-9).ceil() as usize).saturating_sub(1)
            };
            Selection {
                x0: lo(s.x0, fw, tw),
                y0: lo(s.y0, fh, th),
                x1: hi(s.x1, fw, tw),
                y1: hi(s.y1, fh, th),
            }
        };
        out.clamped(to.0, to.1)
    }

    /// "pixel (row y, column x)" or "box (rows y0–y1, columns x0–x1)": the name of its
    /// curve. Rows count from the top, columns from the left, both from 0, as
    /// `tprf sensor --pixel ROW,COLUMN` takes them.
    pub(super) fn label(&self) -> String {
        let s = self.normalized();
        if s.x0 == s.x1 && s.y0 == s.y1 {
            format!("pixel (row {}, column {})", s.y0, s.x0)
        } else {
            format!("box (rows {}–{}, columns {}–{})", s.y0, s.y1, s.x0, s.x1)
        }
    }

    /// Mean TPRF over the box (`layer` None = total).
    pub fn tprf(&self, snap: &FilmSnapshot, layer: Option<usize>) -> Vec<f64> {
        let s = self.normalized();
        snap.box_mean(s.x0, s.y0, s.x1, s.y1, layer)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_selection_follows_its_scene_point_across_resolutions() {
        // Pixel (17, 6) of 24 x 24 covers [17/24, 18/24) x [6/24, 7/24): on 48 x 48 its
        // centre falls in pixel (35, 13), on 12 x 12 in (8, 3).
        let p = Selection::pixel(17, 6);
        assert_eq!(p.rescaled((24, 24), (48, 48)), Selection::pixel(35, 13));
        assert_eq!(p.rescaled((24, 24), (12, 12)), Selection::pixel(8, 3));
        assert_eq!(p.rescaled((24, 24), (24, 24)), p);
        // A box covers the same part of the image: (2..=5) of 8 is [0.25, 0.75).
        let b = Selection {
            x0: 2,
            y0: 0,
            x1: 5,
            y1: 7,
        };
        assert_eq!(
            b.rescaled((8, 8), (16, 4)),
            Selection {
                x0: 4,
                y0: 0,
                x1: 11,
                y1: 3
            }
        );
        // Non-square change and a degenerate film: inside the new film, no panic.
        let r = Selection::pixel(23, 23).rescaled((24, 24), (10, 3));
        assert_eq!(r, Selection::pixel(9, 2));
        let r = Selection::pixel(5, 5).rescaled((0, 0), (0, 0));
        assert_eq!(r, Selection::pixel(0, 0));
    }
}
