//! A smoothness figure for renders: how many pixels well inside the silhouette jump in
//! luminance to a neighbour. Shading discontinuities (facets, crescents at the terminator, a
//! sawtooth shadow boundary) show up as such jumps; a smooth surface under smooth lighting has
//! none at a fine enough resolution.

/// Shading steps of an 8-bit sRGB image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingSteps {
    /// Interior pixels whose luminance differs from the left or upper neighbour by more than the
    /// threshold (in 1/255 units).
    pub count: usize,
    /// The largest such difference among interior pixels (1/255 units).
    pub largest: f32,
    /// Interior pixels: not background, and at least `margin` pixels inside the silhouette.
    pub interior: usize,
}

/// Count the shading steps of an `width × height` 8-bit RGB image (`rgb` interleaved, row-major).
///
/// The background is the top-left pixel's colour; a pixel is part of the object where a channel
/// differs from it by more than 3. The object mask is eroded `margin` times (4-neighbourhood), so
/// anti-aliased silhouette pixels do not count. A pixel steps where its Rec. 709 luminance differs
/// from its left or upper neighbour's by more than `threshold` (1/255 units).
pub fn shading_steps(rgb: &[u8], width: u32, height: u32, threshold: f32, margin: u32) -> ShadingSteps {
    let (w, h) = (width as usize, height as usize);
    assert_eq!(rgb.len(), w * h * 3, "shading_steps: {} bytes for {w}x{h} RGB", rgb.len());
    if w == 0 || h == 0 {
        return ShadingSteps { count: 0, largest: 0.0, interior: 0 };
    }
    // Compute luminance and the object mask.
    let px = |i: usize| [rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]];
    let lum: Vec<f64> = (0..w * h)
        .map(|i| {
            let [r, g, b] = px(i).map(f64::from);
            0.2126 * r + 0.7152 * g + 0.0722 * b
        })
        .collect();
    let bg = px(0);
    let mut mask: Vec<bool> =
        (0..w * h).map(|i| px(i).iter().zip(bg).any(|(&c, b)| (c as i32 - b as i32).abs() > 3)).collect();
    // Erode it, so only pixels well inside the silhouette remain.
    for _ in 0..margin {
        let m = mask.clone();
        let at = |x: isize, y: isize| {
            x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h && m[y as usize * w + x as usize]
        };
        for y in 0..h as isize {
            for x in 0..w as isize {
                mask[y as usize * w + x as usize] =
                    at(x, y) && at(x - 1, y) && at(x + 1, y) && at(x, y - 1) && at(x, y + 1);
            }
        }
    }
    // Compute the steps to the left and upper neighbours.
    let mut out = ShadingSteps { count: 0, largest: 0.0, interior: 0 };
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if !mask[i] {
                continue;
            }
            out.interior += 1;
            let mut s: f64 = 0.0;
            if x > 0 {
                s = s.max((lum[i] - lum[i - 1]).abs());
            }
            if y > 0 {
                s = s.max((lum[i] - lum[i - w]).abs());
            }
            out.largest = out.largest.max(s as f32);
            if s > threshold as f64 {
                out.count += 1;
            }
        }
    }
    out
}

impl super::Image {
    /// The shading steps of this image as it would be written to an 8-bit sRGB PNG (see
    /// [`shading_steps`]).
    pub fn shading_steps(&self, threshold: f32, margin: u32) -> ShadingSteps {
        shading_steps(&self.to_srgb8(), self.width, self.height, threshold, margin)
    }
}
