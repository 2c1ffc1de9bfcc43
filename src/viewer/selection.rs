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

    /// "pixel (x, y)" or "box (x0, y0)–(x1, y1)": the name of its curve.
    pub(super) fn label(&self) -> String {
        let s = self.normalized();
        if s.x0 == s.x1 && s.y0 == s.y1 {
            format!("pixel ({}, {})", s.x0, s.y0)
        } else {
            format!("box ({}, {})–({}, {})", s.x0, s.y0, s.x1, s.y1)
        }
    }

    /// Mean TPRF over the box (`layer` None = total).
    pub fn tprf(&self, snap: &FilmSnapshot, layer: Option<usize>) -> Vec<f64> {
        let s = self.normalized();
        snap.box_mean(s.x0, s.y0, s.x1, s.y1, layer)
    }
}
