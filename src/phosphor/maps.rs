//! Per-pixel decay maps: the decay fit of [`super::decay`] run on every pixel (or every k×k
//! block) of a photo series, tile by tile.
//!
//! For each block the curve is the mean linear value of its unsaturated pixels in each frame,
//! divided by the frame's exposure factor *t* · ISO/100 / *N*² (relative radiance, as
//! [`crate::capture::PhotoSeries::extract`] gives for a region). A block with a saturated pixel in
//! a frame uses the remaining pixels; a block saturated entirely in a frame drops that frame.
//!
//! Weights: a single pixel has no spread to measure, so each sample gets the shot + read noise
//! model of the synthesiser ([`crate::capture::synth`]), σ_t² ∝ p·(0.9·max(y_t, 0) + 0.1·p) with
//! y_t = max_c y_c(t) and p the block's peak: variance proportional to the signal (photon noise)
//! plus a constant read-noise part, 10 % of the variance at the peak. Frames that are only read
//! noise, clipped at the black level (a positive bias), then weigh no more than their noise
//! allows. (Proportional errors with a floor at 1 % of the peak, used before, gave those frames
//! 10⁴ times the weight of the first frame: a fast one-state decay lost to a slow fit of the
//! bias, k ≈ 0.004 s⁻¹ instead of 0.227 s⁻¹ in the left half of `synth phos-decay --layout
//! halves`.)
//!
//! **Tiles.** The pixels are held tile-major ([`TileGrid`], [`SampleEncoding`]): for each square
//! tile of the frame, every frame's pixels of that tile one after the other, so that one tile —
//! all the curves of its blocks — is one contiguous run of bytes. A tile's side is a multiple of
//! the block side, so no block straddles two tiles, and a block's curve (hence its fit) does not
//! depend on the tile size. Where the bytes live (memory or a scratch file) is the caller's
//! business (`io::tiles`); here [`fit_tile`] takes a tile's bytes and returns its blocks' fits.
//!
//! Blocks that cannot be fitted (too few frames, no signal, a fit error) get NaN in every map
//! and are counted in [`PixelMaps::n_failed`]. No file system here: the caller writes the maps.

use rayon::prelude::*;

use crate::capture::{PhotoSeries, RgbFrame};
use crate::error::{Error, Result};

use super::decay::{fit_decay_values, DecayCurve, DecayFitOptions};

/// Read-noise share of the variance at the block's peak in the weights (see the module docs).
pub const READ_NOISE_FRACTION: f64 = 0.1;

/// Number of states reported per block (k1..k3, a1..a3).
pub const MAP_STATES: usize = 3;

/// Number of planes of a [`PixelMaps`] ([`PixelMaps::planes`]).
pub const MAP_PLANES: usize = 2 * MAP_STATES + 3 + 2;

/// Names of the planes, in the order of [`PixelMaps::planes`].
pub const PLANE_NAMES: [&str; MAP_PLANES] = [
    "k1_per_s",
    "k2_per_s",
    "k3_per_s",
    "a1",
    "a2",
    "a3",
    "spectrum_r",
    "spectrum_g",
    "spectrum_b",
    "n_states",
    "rms",
];

/// Fitted parameter maps, row-major, `width × height` blocks. Missing values are NaN.
#[derive(Debug, Clone, PartialEq)]
pub struct PixelMaps {
    /// Width in blocks.
    pub width: usize,
    /// Height in blocks.
    pub height: usize,
    /// Block side in frame pixels.
    pub block: usize,
    /// Rates k_i in s⁻¹, fastest first (k1 ≥ k2 ≥ k3); NaN where the block has fewer states.
    pub k_per_s: [Vec<f32>; MAP_STATES],
    /// Amplitudes a_i (relative radiance at t = 0 per unit spectrum).
    pub amplitude: [Vec<f32>; MAP_STATES],
    /// Shared spectrum r, g, b (largest channel 1, as [`super::DecayFit::spectrum`]).
    pub spectrum: [Vec<f32>; 3],
    /// Chosen number of states n_c (0 where the fit failed).
    pub n_states: Vec<f32>,
    /// Residual RMS of the fit (unweighted, relative radiance, as [`super::DecayFit::rms`]).
    pub rms: Vec<f32>,
    /// Blocks fitted.
    pub n_fitted: usize,
    /// Blocks that could not be fitted.
    pub n_failed: usize,
}

impl PixelMaps {
    /// Maps of `width × height` blocks, every block failed (NaN, n_states 0).
    pub fn failed(width: usize, height: usize, block: usize) -> Self {
        let n = width * height;
        Self {
            width,
            height,
            block,
            k_per_s: std::array::from_fn(|_| vec![f32::NAN; n]),
            amplitude: std::array::from_fn(|_| vec![f32::NAN; n]),
            spectrum: std::array::from_fn(|_| vec![f32::NAN; n]),
            n_states: vec![0.0; n],
            rms: vec![f32::NAN; n],
            n_fitted: 0,
            n_failed: n,
        }
    }

    /// The planes in the order of [`PLANE_NAMES`].
    pub fn planes(&self) -> [&[f32]; MAP_PLANES] {
        [
            &self.k_per_s[0],
            &self.k_per_s[1],
            &self.k_per_s[2],
            &self.amplitude[0],
            &self.amplitude[1],
            &self.amplitude[2],
            &self.spectrum[0],
            &self.spectrum[1],
            &self.spectrum[2],
            &self.n_states,
            &self.rms,
        ]
    }

    /// Mutable planes in the order of [`PLANE_NAMES`].
    pub fn planes_mut(&mut self) -> [&mut Vec<f32>; MAP_PLANES] {
        let [k1, k2, k3] = &mut self.k_per_s;
        let [a1, a2, a3] = &mut self.amplitude;
        let [r, g, b] = &mut self.spectrum;
        [
            k1,
            k2,
            k3,
            a1,
            a2,
            a3,
            r,
            g,
            b,
            &mut self.n_states,
            &mut self.rms,
        ]
    }

    /// Stores the fit of block `i` (row-major index).
    pub fn set(&mut self, i: usize, b: &BlockFit) {
        for s in 0..MAP_STATES {
            self.k_per_s[s][i] = b.k[s];
            self.amplitude[s][i] = b.a[s];
        }
        for c in 0..3 {
            self.spectrum[c][i] = b.spectrum[c];
        }
        self.n_states[i] = b.n_states;
        self.rms[i] = b.rms;
    }

    /// Recounts [`PixelMaps::n_fitted`] and [`PixelMaps::n_failed`] from `n_states`.
    pub fn recount(&mut self) {
        self.n_fitted = self.n_states.iter().filter(|n| **n > 0.0).count();
        self.n_failed = self.n_states.len() - self.n_fitted;
    }

    /// Bytes per block of the maps (the planes as f32).
    pub const BYTES_PER_BLOCK: usize = 4 * MAP_PLANES;
}

/// One block's fitted values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlockFit {
    /// Rates, fastest first (NaN for missing states).
    pub k: [f32; MAP_STATES],
    /// Amplitudes.
    pub a: [f32; MAP_STATES],
    /// Shared spectrum.
    pub spectrum: [f32; 3],
    /// Number of states (0 when failed).
    pub n_states: f32,
    /// Residual RMS.
    pub rms: f32,
}

impl BlockFit {
    /// A block that could not be fitted.
    pub const FAILED: BlockFit = BlockFit {
        k: [f32::NAN; MAP_STATES],
        a: [f32::NAN; MAP_STATES],
        spectrum: [f32::NAN; 3],
        n_states: 0.0,
        rms: f32::NAN,
    };
}

/// How a tile holds its samples (little-endian, three channels per pixel).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SampleEncoding {
    /// 16-bit integer q per channel; the linear value is q/65535 computed in f32, as the image
    /// reader decodes 16-bit PNG and TIFF; q = 65535 in any channel marks the pixel saturated
    /// (the reader's rule). Lossless for 16-bit camera exports, half the bytes of `F32`.
    U16,
    /// f32 per channel; NaN in the first channel marks a saturated pixel.
    F32,
}

impl SampleEncoding {
    /// Bytes per channel value.
    pub fn bytes(self) -> usize {
        match self {
            SampleEncoding::U16 => 2,
            SampleEncoding::F32 => 4,
        }
    }

    /// Whether `frame` is stored without loss as `U16`: every value on the 16-bit grid
    /// (q/65535 in f32 bit for bit) and a pixel flagged saturated exactly when a channel is at
    /// full scale.
    pub fn u16_lossless(frame: &RgbFrame) -> bool {
        frame
            .data()
            .chunks_exact(3)
            .zip(frame.saturation_mask())
            .all(|(px, sat)| {
                let mut full = false;
                for v in px {
                    let q = (*v * 65535.0).round();
                    if !(0.0..=65535.0).contains(&q) || f32::from(q as u16) / 65535.0 != *v {
                        return false;
                    }
                    full |= q == 65535.0;
                }
                full == (*sat != 0)
            })
    }
}

/// Square tiles over a `width × height` frame, row-major; the last column and row of tiles may
/// be narrower.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TileGrid {
    /// Frame width in pixels.
    pub width: usize,
    /// Frame height in pixels.
    pub height: usize,
    /// Tile side in pixels (a multiple of the block side).
    pub tile: usize,
    /// Block side in pixels.
    pub block: usize,
    /// Tiles per row.
    pub tiles_x: usize,
    /// Rows of tiles.
    pub tiles_y: usize,
}

/// A rectangle of frame pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rect {
    /// Left column.
    pub x: usize,
    /// Top row.
    pub y: usize,
    /// Width.
    pub w: usize,
    /// Height.
    pub h: usize,
}

impl TileGrid {
    /// Tiles of side `tile` (rounded down to a multiple of `block`, at least `block`) over a
    /// frame.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] when `block` is 0 or larger than the frame's smaller side, or
    /// `tile` is 0.
    pub fn new(width: usize, height: usize, block: usize, tile: usize) -> Result<Self> {
        if block == 0 || block > width.min(height) {
            return Err(Error::invalid(
                "--block",
                format!(
                    "{block}; expected 1 to {} (the frame's smaller side)",
                    width.min(height)
                ),
            ));
        }
        if tile == 0 {
            return Err(Error::invalid(
                "--tile",
                "0; expected a side of 1 or more pixels",
            ));
        }
        let tile = (tile / block).max(1) * block;
        Ok(Self {
            width,
            height,
            tile,
            block,
            tiles_x: width.div_ceil(tile),
            tiles_y: height.div_ceil(tile),
        })
    }

    /// Number of tiles.
    pub fn n_tiles(&self) -> usize {
        self.tiles_x * self.tiles_y
    }

    /// The pixels of tile `t` (row-major index).
    pub fn rect(&self, t: usize) -> Rect {
        let (tx, ty) = (t % self.tiles_x, t / self.tiles_x);
        let (x, y) = (tx * self.tile, ty * self.tile);
        Rect {
            x,
            y,
            w: self.tile.min(self.width - x),
            h: self.tile.min(self.height - y),
        }
    }

    /// Map size in blocks.
    pub fn map_size(&self) -> (usize, usize) {
        (
            self.width.div_ceil(self.block),
            self.height.div_ceil(self.block),
        )
    }

    /// Block rows covered by tile row `ty`.
    pub fn block_rows(&self, ty: usize) -> std::ops::Range<usize> {
        let per = self.tile / self.block;
        let (_, mh) = self.map_size();
        (ty * per).min(mh)..((ty + 1) * per).min(mh)
    }

    /// Bytes of one tile (all frames) in `enc`.
    pub fn tile_bytes(&self, t: usize, frames: usize, enc: SampleEncoding) -> usize {
        let r = self.rect(t);
        r.w * r.h * frames * 3 * enc.bytes()
    }
}

/// Appends the pixels of `rect` of `frame` to `out` in `enc` (row-major, RGB). With `U16` the
/// frame must be [`SampleEncoding::u16_lossless`] (values are rounded to the 16-bit grid).
pub fn encode_tile(frame: &RgbFrame, rect: Rect, enc: SampleEncoding, out: &mut Vec<u8>) {
    out.reserve(rect.w * rect.h * 3 * enc.bytes());
    let data = frame.data();
    let sat = frame.saturation_mask();
    for y in rect.y..rect.y + rect.h {
        let row = y * frame.width;
        for x in rect.x..rect.x + rect.w {
            let i = row + x;
            let px = &data[3 * i..3 * i + 3];
            match enc {
                SampleEncoding::U16 => {
                    for v in px {
                        let q = (*v * 65535.0).round().clamp(0.0, 65535.0) as u16;
                        out.extend_from_slice(&q.to_le_bytes());
                    }
                }
                SampleEncoding::F32 => {
                    let r = if sat[i] != 0 { f32::NAN } else { px[0] };
                    for v in [r, px[1], px[2]] {
                        out.extend_from_slice(&v.to_le_bytes());
                    }
                }
            }
        }
    }
}

/// Times and exposure factors of the frames of a tile store, with the store's slot of each frame
/// in time order.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameTimes {
    /// Slot (position in the tile's bytes) of each frame, in time order.
    pub slot: Vec<usize>,
    /// Time in s of each frame, in time order.
    pub t_s: Vec<f64>,
    /// Exposure factor *t* · ISO/100 / *N*² of each frame, in time order.
    pub factor: Vec<f64>,
}

/// The bytes of one tile: `frames` frames of `rect.w × rect.h` pixels one after the other (in
/// slot order), and optionally the dark frame's pixels of the tile (F32 encoding) subtracted
/// from every frame (a saturated dark pixel marks the pixel saturated).
#[derive(Debug, Clone, Copy)]
pub struct TileSamples<'a> {
    /// The tile's pixels in the frame.
    pub rect: Rect,
    /// Encoding of `bytes`.
    pub encoding: SampleEncoding,
    /// Number of frames (slots) in `bytes`.
    pub frames: usize,
    /// The samples.
    pub bytes: &'a [u8],
    /// The dark frame's pixels of the tile, F32-encoded, if any.
    pub dark: Option<&'a [u8]>,
}

#[inline]
fn f32_at(b: &[u8], i: usize) -> f32 {
    f32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]])
}

impl TileSamples<'_> {
    /// RGB of tile pixel `p` in slot `slot`, `None` when saturated.
    #[inline]
    fn rgb(&self, slot: usize, p: usize) -> Option<[f32; 3]> {
        let n = self.rect.w * self.rect.h;
        let i = 3 * (slot * n + p);
        let mut v = match self.encoding {
            SampleEncoding::U16 => {
                let b = self.bytes;
                let mut v = [0.0f32; 3];
                let mut full = false;
                for c in 0..3 {
                    let q = u16::from_le_bytes([b[2 * (i + c)], b[2 * (i + c) + 1]]);
                    full |= q == u16::MAX;
                    v[c] = f32::from(q) / 65535.0;
                }
                if full {
                    return None;
                }
                v
            }
            SampleEncoding::F32 => {
                let r = f32_at(self.bytes, i);
                if r.is_nan() {
                    return None;
                }
                [r, f32_at(self.bytes, i + 1), f32_at(self.bytes, i + 2)]
            }
        };
        if let Some(d) = self.dark {
            let r = f32_at(d, 3 * p);
            if r.is_nan() {
                return None;
            }
            v[0] -= r;
            v[1] -= f32_at(d, 3 * p + 1);
            v[2] -= f32_at(d, 3 * p + 2);
        }
        Some(v)
    }

    fn check(&self) -> Result<()> {
        let n = self.rect.w * self.rect.h;
        let want = n * self.frames * 3 * self.encoding.bytes();
        if self.bytes.len() != want {
            return Err(Error::ShapeMismatch {
                what: "tile samples (bytes)".into(),
                expected: want,
                got: self.bytes.len(),
            });
        }
        if let Some(d) = self.dark {
            if d.len() != 12 * n {
                return Err(Error::ShapeMismatch {
                    what: "dark tile (bytes)".into(),
                    expected: 12 * n,
                    got: d.len(),
                });
            }
        }
        Ok(())
    }
}

/// The relative-radiance curve of block (`bx`, `by`) of a tile (block coordinates within the
/// tile), `None` when fewer than 3 frames have unsaturated pixels in it.
fn block_curve(
    tile: &TileSamples<'_>,
    times: &FrameTimes,
    block: usize,
    bx: usize,
    by: usize,
) -> Option<DecayCurve> {
    let n_t = times.slot.len();
    let mut t = Vec::with_capacity(n_t);
    let mut ch: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::with_capacity(n_t));
    let (w, h) = (tile.rect.w, tile.rect.h);
    for ((&slot, &time_s), &k) in times.slot.iter().zip(&times.t_s).zip(&times.factor) {
        let mut sum = [0.0f64; 3];
        let mut n = 0usize;
        for y in by * block..((by + 1) * block).min(h) {
            for x in bx * block..((bx + 1) * block).min(w) {
                let Some(v) = tile.rgb(slot, y * w + x) else {
                    continue;
                };
                for c in 0..3 {
                    sum[c] += f64::from(v[c]);
                }
                n += 1;
            }
        }
        if n == 0 {
            continue;
        }
        t.push(time_s);
        for c in 0..3 {
            ch[c].push(sum[c] / n as f64 / k);
        }
    }
    if t.len() < 3 {
        return None;
    }
    let peak = ch
        .iter()
        .flat_map(|c| c.iter())
        .cloned()
        .fold(0.0f64, f64::max);
    if !(peak > 0.0 && peak.is_finite()) {
        return None;
    }
    let sigma: Vec<f64> = (0..t.len())
        .map(|j| {
            let m = ch.iter().map(|c| c[j]).fold(0.0f64, f64::max).max(0.0);
            (peak * ((1.0 - READ_NOISE_FRACTION) * m + READ_NOISE_FRACTION * peak)).sqrt()
        })
        .collect();
    DecayCurve::new(t, ch.to_vec(), Some(sigma)).ok()
}

fn fit_curve(curve: Option<DecayCurve>, opts: &DecayFitOptions) -> BlockFit {
    let Some(curve) = curve else {
        return BlockFit::FAILED;
    };
    let Ok(fit) = fit_decay_values(&curve, opts) else {
        return BlockFit::FAILED;
    };
    if !fit.rms.is_finite() {
        return BlockFit::FAILED;
    }
    let mut out = BlockFit::FAILED;
    // the fit sorts states by decreasing rate: k1 is the fastest
    for (i, s) in fit.states.iter().take(MAP_STATES).enumerate() {
        out.k[i] = s.k_per_s as f32;
        out.a[i] = s.amplitude as f32;
    }
    for (c, v) in fit.spectrum.iter().take(3).enumerate() {
        out.spectrum[c] = *v as f32;
    }
    out.n_states = fit.states.len() as f32;
    out.rms = fit.rms as f32;
    out
}

/// Fits every `block × block` block of one tile (rows of blocks in parallel) and returns the
/// fits row-major over the tile's blocks (`ceil(w/block) × ceil(h/block)`); `progress` is
/// called once per finished row of blocks, from worker threads.
///
/// # Errors
/// [`Error::ShapeMismatch`] when the bytes do not hold the tile; [`Error::InvalidArgument`] for a
/// zero block or fewer than 3 frames.
pub fn fit_tile(
    tile: &TileSamples<'_>,
    times: &FrameTimes,
    block: usize,
    opts: &DecayFitOptions,
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<BlockFit>> {
    tile.check()?;
    if block == 0 {
        return Err(Error::invalid("--block", "0; expected 1 or more"));
    }
    if times.slot.len() < 3 {
        return Err(Error::invalid(
            "series",
            format!("{} frames; a decay fit needs at least 3", times.slot.len()),
        ));
    }
    if let Some(s) = times.slot.iter().find(|s| **s >= tile.frames) {
        return Err(Error::invalid(
            "tile",
            format!("frame slot {s} of {} frames", tile.frames),
        ));
    }
    let (bw, bh) = (tile.rect.w.div_ceil(block), tile.rect.h.div_ceil(block));
    let rows: Vec<Vec<BlockFit>> = (0..bh)
        .into_par_iter()
        .map(|by| {
            let row = (0..bw)
                .map(|bx| fit_curve(block_curve(tile, times, block, bx, by), opts))
                .collect();
            progress();
            row
        })
        .collect();
    Ok(rows.into_iter().flatten().collect())
}

/// Writes the fits of tile `t` of `grid` (as [`fit_tile`] returns them) into `maps`, whose
/// first row is block row `row0` of the full map.
pub fn place_tile(maps: &mut PixelMaps, grid: &TileGrid, t: usize, row0: usize, fits: &[BlockFit]) {
    let r = grid.rect(t);
    let (bx0, by0) = (r.x / grid.block, r.y / grid.block);
    let bw = r.w.div_ceil(grid.block);
    for (k, f) in fits.iter().enumerate() {
        let (x, y) = (bx0 + k % bw, by0 + k / bw);
        if y >= row0 && y - row0 < maps.height && x < maps.width {
            maps.set((y - row0) * maps.width + x, f);
        }
    }
}

/// Fits every `block × block` block of `series` (block 1 = every pixel) held in memory, tile by
/// tile; `progress` is called once per finished row of blocks within a tile, from worker
/// threads. The same arithmetic as the streamed per-pixel run (`pipeline::phos_maps`).
///
/// # Errors
/// [`Error::InvalidArgument`] when `block` is 0 or larger than the frame, or the series has fewer
/// than 3 frames.
pub fn fit_pixel_maps(
    series: &PhotoSeries,
    block: usize,
    opts: &DecayFitOptions,
    progress: &(dyn Fn() + Sync),
) -> Result<PixelMaps> {
    let Some(first) = series.frames().first() else {
        return Err(Error::invalid("series", "no frames; expected at least 3"));
    };
    if series.len() < 3 {
        return Err(Error::invalid(
            "series",
            format!("{} frames; a decay fit needs at least 3", series.len()),
        ));
    }
    let (w, h) = (first.frame.width, first.frame.height);
    let grid = TileGrid::new(w, h, block, 256)?;
    let times = FrameTimes {
        slot: (0..series.len()).collect(),
        t_s: series.frames().iter().map(|f| f.time_s).collect(),
        factor: series
            .frames()
            .iter()
            .map(|f| f.exposure.factor())
            .collect(),
    };
    let (mw, mh) = grid.map_size();
    let mut maps = PixelMaps::failed(mw, mh, block);
    let mut bytes = Vec::new();
    for t in 0..grid.n_tiles() {
        let rect = grid.rect(t);
        bytes.clear();
        for f in series.frames() {
            encode_tile(&f.frame, rect, SampleEncoding::F32, &mut bytes);
        }
        let tile = TileSamples {
            rect,
            encoding: SampleEncoding::F32,
            frames: series.len(),
            bytes: &bytes,
            dark: None,
        };
        let fits = fit_tile(&tile, &times, block, opts, progress)?;
        place_tile(&mut maps, &grid, t, 0, &fits);
    }
    maps.recount();
    Ok(maps)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(w: usize, h: usize, f: impl Fn(usize, usize) -> [f32; 3]) -> RgbFrame {
        let mut data = Vec::new();
        let mut sat = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let v = f(x, y);
                sat.push(u8::from(v.contains(&1.0)));
                data.extend(v);
            }
        }
        RgbFrame::new("t", w, h, 1, data, sat).unwrap()
    }

    #[test]
    fn u16_and_f32_tiles_give_the_same_samples() {
        let fr = frame(5, 3, |x, y| {
            let q = (x * 1000 + y * 7) as u16;
            [
                f32::from(q) / 65535.0,
                if x == 4 { 1.0 } else { 30000.0 / 65535.0 },
                0.0,
            ]
        });
        assert!(SampleEncoding::u16_lossless(&fr));
        let rect = Rect {
            x: 1,
            y: 1,
            w: 4,
            h: 2,
        };
        for enc in [SampleEncoding::U16, SampleEncoding::F32] {
            let mut b = Vec::new();
            encode_tile(&fr, rect, enc, &mut b);
            let t = TileSamples {
                rect,
                encoding: enc,
                frames: 1,
                bytes: &b,
                dark: None,
            };
            for p in 0..8 {
                let (x, y) = (1 + p % 4, 1 + p / 4);
                let want = (fr.saturation_bits(x, y) == 0).then(|| fr.rgb(x, y));
                assert_eq!(t.rgb(0, p), want, "{enc:?} pixel {p}");
            }
        }
    }

    #[test]
    fn a_value_off_the_16_bit_grid_is_not_u16_lossless() {
        let fr = frame(2, 2, |_, _| [0.123_456_7, 0.0, 0.0]);
        assert!(!SampleEncoding::u16_lossless(&fr));
    }

    #[test]
    fn tiles_are_multiples_of_the_block_and_cover_the_frame() {
        let g = TileGrid::new(10, 7, 3, 5).unwrap();
        assert_eq!((g.tile, g.tiles_x, g.tiles_y), (3, 4, 3));
        let area: usize = (0..g.n_tiles()).map(|t| g.rect(t).w * g.rect(t).h).sum();
        assert_eq!(area, 70);
        assert_eq!(g.map_size(), (4, 3));
        assert_eq!(g.block_rows(2), 2..3);
    }
}
