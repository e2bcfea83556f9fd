//! Image patches and their normalised cross-correlation search.
//!
//! A feature's appearance is the square patch around its first sighting. It is found again
//! in a later image by normalised cross-correlation (NCC: the patches' correlation after
//! removing their mean and scaling by their spread, so brightness and contrast changes do not
//! matter) at every pixel inside the search region the filter predicts, and placed to a
//! fraction of a pixel by fitting a parabola through the best score and its neighbours.

use image::GrayImage;

/// A patch, kept with zero mean and unit norm for the correlation.
#[derive(Clone, Debug, PartialEq)]
pub struct Patch {
    half_px: u32,
    /// Row-major, `(2 half + 1)²` values.
    values: Vec<f32>,
}

impl Patch {
    /// The patch of half size `half_px` centred on the pixel `centre`, or `None` when it does
    /// not fit in the image or the image is flat there (nothing to correlate).
    pub fn from_image(image: &GrayImage, centre: [i64; 2], half_px: u32) -> Option<Self> {
        let values = sample(image, centre, half_px)?;
        normalise(values).map(|values| Patch { half_px, values })
    }

    /// The patch of half size `half_px` from its values (row-major), or `None` when they are
    /// flat or not `(2 half + 1)²`.
    pub fn from_values(values: Vec<f32>, half_px: u32) -> Option<Self> {
        let side = 2 * half_px as usize + 1;
        if values.len() != side * side {
            return None;
        }
        normalise(values).map(|values| Patch { half_px, values })
    }

    /// The NCC of two patches of one size (−1 to 1; 0 for patches of different sizes).
    pub fn correlation_with(&self, other: &Patch) -> f32 {
        if self.values.len() != other.values.len() {
            return 0.0;
        }
        self.values
            .iter()
            .zip(&other.values)
            .map(|(a, b)| a * b)
            .sum()
    }

    /// Half the side, pixels.
    pub fn half_px(&self) -> u32 {
        self.half_px
    }

    /// The NCC of this patch with the image's around `centre` (−1 to 1), or `None` where the
    /// image's patch does not fit or is flat.
    pub fn correlation(&self, image: &GrayImage, centre: [i64; 2]) -> Option<f32> {
        if !fits(image, centre, self.half_px) {
            return None;
        }
        let half = i64::from(self.half_px);
        let width = i64::from(image.width());
        // The template has zero mean, so the image patch's mean drops out of the product and
        // only its spread is needed: one pass, nothing allocated.
        let side = (2 * half + 1) as usize;
        let raw = image.as_raw();
        let (mut product, mut sum, mut squares) = (0f32, 0f32, 0f32);
        for (row, template_row) in self.values.chunks_exact(side).enumerate() {
            let start = ((centre[1] - half + row as i64) * width + centre[0] - half) as usize;
            for (t, &v) in template_row.iter().zip(&raw[start..start + side]) {
                let v = f32::from(v);
                product += t * v;
                sum += v;
                squares += v * v;
            }
        }
        let n = self.values.len() as f32;
        let spread = (squares - sum * sum / n).max(0.0).sqrt();
        // As in `normalise`: below about one grey level per pixel there is no texture.
        (spread >= n.sqrt()).then(|| product / spread)
    }
}

/// Whether the square of half size `half_px` around `centre` lies inside the image.
fn fits(image: &GrayImage, centre: [i64; 2], half_px: u32) -> bool {
    let half = i64::from(half_px);
    centre[0] - half >= 0
        && centre[1] - half >= 0
        && centre[0] + half < i64::from(image.width())
        && centre[1] + half < i64::from(image.height())
}

/// The image's values in the square of half size `half_px` around `centre`, row-major.
pub(super) fn sample(image: &GrayImage, centre: [i64; 2], half_px: u32) -> Option<Vec<f32>> {
    if !fits(image, centre, half_px) {
        return None;
    }
    let half = i64::from(half_px);
    let width = i64::from(image.width());
    let side = (2 * half + 1) as usize;
    let mut values = Vec::with_capacity(side * side);
    let raw = image.as_raw();
    for y in centre[1] - half..=centre[1] + half {
        let row = (y * width) as usize;
        for x in centre[0] - half..=centre[0] + half {
            values.push(f32::from(raw[row + x as usize]));
        }
    }
    Some(values)
}

/// `values` less their mean, scaled to unit norm; `None` when they are all but constant.
fn normalise(mut values: Vec<f32>) -> Option<Vec<f32>> {
    let mean = values.iter().sum::<f32>() / values.len() as f32;
    values.iter_mut().for_each(|v| *v -= mean);
    let norm = values.iter().map(|v| v * v).sum::<f32>().sqrt();
    // Below about one grey level of spread per pixel there is no texture to match.
    if norm < (values.len() as f32).sqrt() {
        return None;
    }
    values.iter_mut().for_each(|v| *v /= norm);
    Some(values)
}

/// Positions scored together: the correlation of one template with eight neighbouring
/// image windows, each lane summing its products in the order [`Patch::correlation`] does, so
/// every score is the same to the bit while the compiler runs the lanes side by side.
const LANES: usize = 8;

/// The best integer position and score of `patch` among the pixels `inside` admits within
/// `box_px` where the patch fits in the image; the first in row-major order on a tie.
///
/// On x86-64 CPUs with AVX2 the body runs as compiled for it, the eight lanes in one vector
/// instead of two: the same multiplications and additions in the same order (no fused
/// multiply-add), so the same scores to the bit on any CPU.
fn best_in_box(
    patch: &Patch,
    image: &GrayImage,
    box_px: [[i64; 2]; 2],
    inside: &impl Fn([i64; 2]) -> bool,
) -> Option<([i64; 2], f32)> {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2, the one feature this build is compiled for.
        return unsafe { best_in_box_avx2(patch, image, box_px, inside) };
    }
    best_in_box_body(patch, image, box_px, inside)
}

/// [`best_in_box`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn best_in_box_avx2(
    patch: &Patch,
    image: &GrayImage,
    box_px: [[i64; 2]; 2],
    inside: &impl Fn([i64; 2]) -> bool,
) -> Option<([i64; 2], f32)> {
    best_in_box_body(patch, image, box_px, inside)
}

/// The body of [`best_in_box`], inlined into each build of it.
#[inline(always)]
fn best_in_box_body(
    patch: &Patch,
    image: &GrayImage,
    box_px: [[i64; 2]; 2],
    inside: &impl Fn([i64; 2]) -> bool,
) -> Option<([i64; 2], f32)> {
    let half = i64::from(patch.half_px);
    let side = (2 * half + 1) as usize;
    // Window sums are exact in f32 only below 2^24 (patches up to 15 × 15).
    if (side * side) as u64 * 255 * 255 >= 1 << 24 {
        return best_one_at_a_time(patch, image, box_px, inside);
    }
    let (width, height) = (i64::from(image.width()), i64::from(image.height()));
    let [min, max] = box_px;
    let (x0, x1) = (min[0].max(half), max[0].min(width - 1 - half));
    let (y0, y1) = (min[1].max(half), max[1].min(height - 1 - half));
    if x0 > x1 || y0 > y1 {
        return None;
    }
    let columns = (x1 - x0 + 1) as usize;
    // The box's pixels with the patch's margin, as f32, each row padded for the last block.
    let span = columns + side - 1 + LANES;
    let rows = (y1 - y0) as usize + side;
    let mut strip = vec![0f32; rows * span];
    // Running sums of the pixels and their squares over the strip, with a zero row and
    // column first: a window's sums from four entries. Integers, so exact; and below 2^24,
    // so the same to the bit as summing the window's pixels in f32 one by one.
    let mut sums = vec![0u64; (rows + 1) * (span + 1)];
    let mut squares = vec![0u64; (rows + 1) * (span + 1)];
    let raw = image.as_raw();
    for (r, row) in strip.chunks_exact_mut(span).enumerate() {
        let start = ((y0 - half + r as i64) * width + x0 - half) as usize;
        let (mut row_sum, mut row_squares) = (0u64, 0u64);
        for (c, (out, &v)) in row
            .iter_mut()
            .zip(&raw[start..start + columns + side - 1])
            .enumerate()
        {
            *out = f32::from(v);
            row_sum += u64::from(v);
            row_squares += u64::from(v) * u64::from(v);
            let at = (r + 1) * (span + 1) + c + 1;
            sums[at] = sums[at - span - 1] + row_sum;
            squares[at] = squares[at - span - 1] + row_squares;
        }
    }
    let window = |table: &[u64], top: usize, left: usize| -> f32 {
        let (bottom, right) = (top + side, left + side);
        let at = |r: usize, c: usize| table[r * (span + 1) + c];
        (at(bottom, right) + at(top, left) - at(top, right) - at(bottom, left)) as f32
    };
    let n = patch.values.len() as f32;
    let mut best: Option<([i64; 2], f32)> = None;
    for y in y0..=y1 {
        let top = (y - y0) as usize;
        for block in (0..columns).step_by(LANES) {
            let mut wanted = [false; LANES];
            for (k, w) in wanted.iter_mut().enumerate() {
                *w = block + k < columns && inside([x0 + (block + k) as i64, y]);
            }
            if !wanted.contains(&true) {
                continue;
            }
            let mut product = [0f32; LANES];
            for (r, template_row) in patch.values.chunks_exact(side).enumerate() {
                let row = &strip[(top + r) * span + block..];
                for (j, &t) in template_row.iter().enumerate() {
                    let v = &row[j..j + LANES];
                    for k in 0..LANES {
                        product[k] += t * v[k];
                    }
                }
            }
            for k in 0..LANES {
                if !wanted[k] {
                    continue;
                }
                let sum = window(&sums, top, block + k);
                let spread = (window(&squares, top, block + k) - sum * sum / n)
                    .max(0.0)
                    .sqrt();
                if spread < n.sqrt() {
                    continue;
                }
                let score = product[k] / spread;
                if best.is_none_or(|(_, b)| score > b) {
                    best = Some(([x0 + (block + k) as i64, y], score));
                }
            }
        }
    }
    best
}

/// [`best_in_box`] with every pixel of the box scored one at a time by
/// [`Patch::correlation`].
fn best_one_at_a_time(
    patch: &Patch,
    image: &GrayImage,
    box_px: [[i64; 2]; 2],
    inside: &impl Fn([i64; 2]) -> bool,
) -> Option<([i64; 2], f32)> {
    let mut best: Option<([i64; 2], f32)> = None;
    for y in box_px[0][1]..=box_px[1][1] {
        for x in box_px[0][0]..=box_px[1][0] {
            if !inside([x, y]) {
                continue;
            }
            if let Some(score) = patch.correlation(image, [x, y])
                && best.is_none_or(|(_, b)| score > b)
            {
                best = Some(([x, y], score));
            }
        }
    }
    best
}

/// The best match of `patch` among the pixels `inside` admits within `box_px` (inclusive
/// min and max corners), refined to a fraction of a pixel, with its correlation.
pub fn search(
    patch: &Patch,
    image: &GrayImage,
    box_px: [[i64; 2]; 2],
    inside: impl Fn([i64; 2]) -> bool,
) -> Option<([f64; 2], f32)> {
    let best = best_in_box(patch, image, box_px, &inside);
    let (at, score) = best?;
    // A parabola through the neighbours on each axis.
    let offset = |before: Option<f32>, after: Option<f32>| match (before, after) {
        (Some(b), Some(a)) => {
            let curvature = b - 2.0 * score + a;
            if curvature < 0.0 {
                f64::from(0.5 * (b - a) / curvature).clamp(-0.5, 0.5)
            } else {
                0.0
            }
        }
        _ => 0.0,
    };
    let dx = offset(
        patch.correlation(image, [at[0] - 1, at[1]]),
        patch.correlation(image, [at[0] + 1, at[1]]),
    );
    let dy = offset(
        patch.correlation(image, [at[0], at[1] - 1]),
        patch.correlation(image, [at[0], at[1] + 1]),
    );
    Some(([at[0] as f64 + dx, at[1] as f64 + dy], score))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth blob pattern.
    fn textured(width: u32, height: u32, shift: [f64; 2]) -> GrayImage {
        GrayImage::from_fn(width, height, |x, y| {
            let (x, y) = (f64::from(x) - shift[0], f64::from(y) - shift[1]);
            let v = 128.0
                + 60.0 * (x * 0.31).sin() * (y * 0.23).cos()
                + 40.0 * (x * 0.07 + y * 0.11).sin();
            image::Luma([v.clamp(0.0, 255.0) as u8])
        })
    }

    #[test]
    fn a_patch_is_found_where_the_image_moved_it() {
        let first = textured(80, 60, [0.0, 0.0]);
        let patch = Patch::from_image(&first, [40, 30], 5).expect("textured");
        let moved = textured(80, 60, [3.0, -2.0]);
        let (found, score) = search(&patch, &moved, [[30, 20], [50, 40]], |_| true).expect("found");
        assert!(score > 0.95, "{score}");
        assert!(
            (found[0] - 43.0).abs() < 0.3 && (found[1] - 28.0).abs() < 0.3,
            "{found:?}"
        );
    }

    #[test]
    fn the_search_scores_every_pixel_exactly_as_one_correlation_does() {
        let first = textured(120, 90, [0.0, 0.0]);
        let moved = textured(120, 90, [2.6, -1.3]);
        let ellipse = |c: [i64; 2]| {
            move |p: [i64; 2]| {
                let (dx, dy) = ((p[0] - c[0]) as f64, (p[1] - c[1]) as f64);
                (dx + 0.5 * dy).powi(2) / 400.0 + dy * dy / 16.0 <= 1.0
            }
        };
        for (centre, box_px) in [
            ([60, 45], [[40, 30], [80, 60]]),
            ([10, 10], [[-20, -20], [30, 25]]),
            ([110, 80], [[90, 70], [140, 120]]),
            ([60, 45], [[59, 44], [61, 46]]),
        ] {
            let patch = Patch::from_image(&first, centre, 5).expect("textured");
            for inside in [&ellipse(centre) as &dyn Fn([i64; 2]) -> bool, &|_| true] {
                assert_eq!(
                    best_in_box(&patch, &moved, box_px, &inside),
                    best_one_at_a_time(&patch, &moved, box_px, &inside),
                    "{centre:?} {box_px:?}"
                );
                // The baseline build, whichever one `best_in_box` runs on this CPU.
                assert_eq!(
                    best_in_box_body(&patch, &moved, box_px, &inside),
                    best_one_at_a_time(&patch, &moved, box_px, &inside),
                    "{centre:?} {box_px:?}"
                );
            }
        }
        let patch = Patch::from_image(&first, [60, 45], 5).expect("textured");
        assert_eq!(
            best_in_box(&patch, &moved, [[200, 200], [210, 210]], &|_| true),
            None
        );
    }

    #[test]
    fn a_flat_patch_or_one_off_the_image_is_refused() {
        let flat = GrayImage::from_pixel(40, 40, image::Luma([90]));
        assert!(Patch::from_image(&flat, [20, 20], 5).is_none());
        let first = textured(80, 60, [0.0, 0.0]);
        assert!(Patch::from_image(&first, [2, 30], 5).is_none());
    }
}
