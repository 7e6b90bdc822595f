//! Bounds of a per-pixel quantity of a view's image over any rectangle of pixels, read from
//! a pyramid of tiles (2 × 2, 4 × 4, ... pixels) in a few lookups: what a voxel block's
//! footprint in the image may see, so that a block all of whose nodes a view leaves alone,
//! or marks alike, is decided once instead of node by node (`tsdf`).

use crate::budget;
use crate::error::Result;
use rayon::prelude::*;

/// What the pixels of a rectangle hold: the range of their values and the smallest cosine
/// over those that have one, how many have none (NaN) and how many there are.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Bounds {
    /// Smallest value (+∞: no pixel has one).
    pub lo: f64,
    /// Largest value (−∞: no pixel has one).
    pub hi: f64,
    /// Smallest cosine of the pixels with a value (+∞: none).
    pub cos: f64,
    /// Pixels without a value.
    pub missing: u64,
    /// Pixels.
    pub pixels: u64,
}

impl Bounds {
    const NONE: Self = Self {
        lo: f64::INFINITY,
        hi: f64::NEG_INFINITY,
        cos: f64::INFINITY,
        missing: 0,
        pixels: 0,
    };

    fn pixel(value: f64, cos: f64) -> Self {
        if value.is_nan() {
            Self {
                missing: 1,
                pixels: 1,
                ..Self::NONE
            }
        } else {
            Self {
                lo: value,
                hi: value,
                cos,
                missing: 0,
                pixels: 1,
            }
        }
    }

    fn join(self, o: Self) -> Self {
        Self {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
            cos: self.cos.min(o.cos),
            missing: self.missing + o.missing,
            pixels: self.pixels + o.pixels,
        }
    }
}

/// A `width × height` image of values (row-major, NaN: none) with a cosine per pixel, and
/// its pyramid: level `l` (from 1) holds the bounds of tiles of 2^l × 2^l pixels.
pub(super) struct Footprint<'a> {
    width: usize,
    height: usize,
    values: &'a [f64],
    cos: Option<&'a [f64]>,
    /// Per level from 1: (tiles across, the tiles row by row).
    levels: Vec<(usize, Vec<Bounds>)>,
}

impl<'a> Footprint<'a> {
    /// The pyramid of `values` (and `cos`, 1 where absent). O(pixels), on every core;
    /// a third of a [`Bounds`] per pixel.
    ///
    /// Errors: `OutOfMemory` when the pyramid does not fit.
    pub(super) fn new(
        width: usize,
        height: usize,
        values: &'a [f64],
        cos: Option<&'a [f64]>,
    ) -> Result<Self> {
        let mut out = Self {
            width,
            height,
            values,
            cos,
            levels: Vec::new(),
        };
        let (mut w, mut h) = (width, height);
        while w > 1 || h > 1 {
            let (tw, th) = (w.div_ceil(2), h.div_ceil(2));
            let level = out.levels.len() + 1;
            let below = |i: usize, j: usize| -> Bounds {
                if i >= w || j >= h {
                    return Bounds::NONE;
                }
                match out.levels.last() {
                    Some((across, tiles)) => tiles[j * across + i],
                    None => out.pixel(j * width + i),
                }
            };
            let tiles = budget::try_par_collect(
                "the bounds of a view's image",
                (0..tw * th).into_par_iter().map(|t| {
                    let (i, j) = (2 * (t % tw), 2 * (t / tw));
                    below(i, j)
                        .join(below(i + 1, j))
                        .join(below(i, j + 1))
                        .join(below(i + 1, j + 1))
                }),
            )?;
            debug_assert_eq!(out.levels.len() + 1, level);
            out.levels.push((tw, tiles));
            (w, h) = (tw, th);
        }
        Ok(out)
    }

    fn pixel(&self, at: usize) -> Bounds {
        Bounds::pixel(self.values[at], self.cos.map_or(1.0, |c| c[at]))
    }

    /// Bounds over at least the pixels `i0..=i1` across and `j0..=j1` down (inside the
    /// image, not empty), at most a few times as many: the tiles of the coarsest level
    /// under half the rectangle's side that cover it. O(1).
    pub(super) fn query(&self, [i0, i1]: [usize; 2], [j0, j1]: [usize; 2]) -> Bounds {
        debug_assert!(i0 <= i1 && j0 <= j1 && i1 < self.width && j1 < self.height);
        let span = (i1 - i0 + 1).max(j1 - j0 + 1);
        // the level whose tiles are at least half the span: 3 × 3 tiles at most
        let level = (usize::BITS - (span / 2).leading_zeros()) as usize;
        let level = level.min(self.levels.len());
        let mut out = Bounds::NONE;
        if level == 0 {
            for j in j0..=j1 {
                for i in i0..=i1 {
                    out = out.join(self.pixel(j * self.width + i));
                }
            }
            return out;
        }
        let (across, tiles) = &self.levels[level - 1];
        for j in j0 >> level..=j1 >> level {
            for i in i0 >> level..=i1 >> level {
                out = out.join(tiles[j * across + i]);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bounds_of_a_rectangle_hold_every_pixel_in_it() {
        let (w, h) = (37, 23);
        let values: Vec<f64> = (0..w * h)
            .map(|p| {
                if p % 11 == 3 {
                    f64::NAN
                } else {
                    ((p * 7919) % 101) as f64
                }
            })
            .collect();
        let cos: Vec<f64> = (0..w * h).map(|p| 0.1 + (p % 13) as f64 / 20.0).collect();
        let foot = Footprint::new(w, h, &values, Some(&cos)).unwrap();
        for (i0, i1, j0, j1) in [(0, 0, 0, 0), (3, 9, 2, 4), (0, 36, 0, 22), (30, 36, 20, 22)] {
            let b = foot.query([i0, i1], [j0, j1]);
            let mut exact = Bounds::NONE;
            for j in j0..=j1 {
                for i in i0..=i1 {
                    exact = exact.join(Bounds::pixel(values[j * w + i], cos[j * w + i]));
                }
            }
            // a superset: wider or equal bounds, at least the rectangle's pixels
            assert!(b.lo <= exact.lo && b.hi >= exact.hi && b.cos <= exact.cos);
            assert!(b.missing >= exact.missing && b.pixels >= exact.pixels);
            let span = (i1 - i0 + 1).max(j1 - j0 + 1) as u64;
            assert!(b.pixels <= 4 * span * span);
            // a rectangle without a missing pixel can be all present
            if exact.missing == 0 && b.missing == 0 {
                assert!(b.lo.is_finite());
            }
        }
        let whole = foot.query([0, 36], [0, 22]);
        assert_eq!(whole.pixels, (w * h) as u64);
        assert_eq!(
            whole.missing,
            values.iter().filter(|v| v.is_nan()).count() as u64
        );
    }
}
