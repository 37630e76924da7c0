//! Per-pixel decay maps at camera resolution (`phos fit-decay --per-pixel`, `phos merge-maps`):
//! a photo series decoded once into a tile store ([`crate::io::tiles`]), fitted tile by tile
//! ([`crate::phosphor::maps::fit_tile`]) within a memory budget, optionally one shard of it,
//! and the map files.
//!
//! **Memory plan** ([`plan`]). The peak is the largest of three phases, each estimated before
//! anything is allocated:
//! - decoding: frames decoded at once × [`DECODE_BYTES_PER_PX`] × pixels, plus the dark frame
//!   and the store when it is in memory;
//! - fitting: the maps ([`PixelMaps::BYTES_PER_BLOCK`] per block of the shard), one tile's bytes
//!   (when read from the scratch file), the dark frame and the store when in memory;
//! - writing: the maps plus one map being encoded ([`WRITE_BYTES_PER_BLOCK`] per block; the
//!   store is gone by then).
//!
//! The store goes into memory when the peak with it fits the budget, else into a scratch file;
//! when even that does not fit, fewer frames are decoded at once, and as a last resort the run
//! is refused ([`Error::TooLarge`] naming `--memory-gb`).
//!
//! **Shards** ([`Shard`]): the tile rows are split into `n` contiguous groups; shard `i` fits the
//! blocks of group `i` and writes them as `maps.f32le` (the map planes of its block rows, f32
//! little-endian, plane after plane) with `shard.json` ([`ShardManifest`]). [`merge_shards`]
//! checks that the shards belong to one run (the same series, options and sizes, by a
//! fingerprint), that every block row is held by exactly one shard, and the SHA-256 of each
//! data file, then assembles the maps — the same `f32` values a single run computes, so its map
//! files are byte-identical to a single run's.

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::capture::{FrameInfo, RgbFrame};
use crate::error::{Error, Result};
use crate::io::series::{
    directory_frames, parse_manifest, read_frame, resolve_exposure, ManifestRow,
};
use crate::io::tiles::{Storage, TileStore};
use crate::phosphor::maps::{
    fit_tile, place_tile, FrameTimes, PixelMaps, SampleEncoding, TileGrid, MAP_PLANES, PLANE_NAMES,
};
use crate::phosphor::DecayFitOptions;
use crate::preset::sha256_hex;

/// Bytes per pixel of one frame while it is decoded: the file (16-bit RGB, 6), the decoder's
/// image (6) and its RGB copy (6), the linear f32 frame (12) and its saturation mask (1), rounded
/// up.
pub const DECODE_BYTES_PER_PX: u128 = 32;
/// Bytes per block of writing one float TIFF map: the RGB f32 copy, its bytes, the encoded file.
pub const WRITE_BYTES_PER_BLOCK: u128 = 36;
/// The process without its data (code, thread stacks, allocator slack), in bytes.
pub const BASE_BYTES: u128 = 64 << 20;
/// Default tile size: the side that makes one tile (all frames) about this many bytes.
pub const TILE_TARGET_BYTES: usize = 32 << 20;

/// Shard `index` of `count` (0-based, as `$SLURM_ARRAY_TASK_ID` and `$JOB_COMPLETION_INDEX`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// 0-based index.
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

impl Shard {
    /// Parses `i/n` (0 ≤ i < n).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] naming `--shard`.
    pub fn parse(s: &str) -> Result<Self> {
        let bad = || {
            Error::invalid(
                "--shard",
                format!("'{s}'; expected i/n with 0 ≤ i < n, e.g. 0/4 (i is 0-based, as $SLURM_ARRAY_TASK_ID)"),
            )
        };
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count): (usize, usize) = (
            i.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Self { index, count })
    }
}

/// What a per-pixel run needs besides the series and the fit options.
#[derive(Debug, Clone)]
pub struct PerPixelConfig {
    /// Block side in pixels.
    pub block: usize,
    /// Tile side in pixels; `None` for the default ([`TILE_TARGET_BYTES`]).
    pub tile: Option<usize>,
    /// Memory budget in MiB.
    pub memory_mib: u64,
    /// Folder for the scratch file.
    pub scratch_dir: PathBuf,
    /// The shard to fit, or all.
    pub shard: Option<Shard>,
    /// Dark frames, averaged and subtracted.
    pub darks: Vec<PathBuf>,
    /// Worker threads (frames decoded at once at most).
    pub threads: usize,
}

/// The memory plan of a run (reported in the summary).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Plan {
    /// Frame size in pixels.
    pub frame_size: [usize; 2],
    /// Frames.
    pub frames: usize,
    /// Block side.
    pub block: usize,
    /// Tile side in pixels.
    pub tile_px: usize,
    /// Tiles over the frame.
    pub tiles: usize,
    /// Tiles fitted here (`[first, end)`).
    pub tiles_held: [usize; 2],
    /// Block rows fitted here (`[first, end)`).
    pub block_rows: [usize; 2],
    /// Full map size in blocks.
    pub map_size: [usize; 2],
    /// Sample encoding of the store.
    pub encoding: SampleEncoding,
    /// `memory` or `scratch file`.
    pub storage: String,
    /// Size of the store in MiB.
    pub store_mib: f64,
    /// Frames decoded at once.
    pub frames_in_flight: usize,
    /// Estimated peak memory in MiB (the largest phase).
    pub peak_estimate_mib: f64,
    /// The budget in MiB.
    pub budget_mib: u64,
    /// The shard fitted, if not all.
    pub shard: Option<Shard>,
    /// Rows of blocks to fit (summed over tiles), for a progress bar.
    #[serde(skip)]
    pub fit_units: u64,
    #[serde(skip)]
    storage_kind: Storage,
}

fn mib(b: u128) -> f64 {
    b as f64 / (1024.0 * 1024.0)
}

/// Plans a run over `frames` frames of `width × height` pixels (see the module docs).
///
/// # Errors
/// [`Error::InvalidArgument`] for a bad block, tile or shard; [`Error::TooLarge`] naming
/// `--memory-gb` when no plan fits the budget.
pub fn plan(
    width: usize,
    height: usize,
    frames: usize,
    encoding: SampleEncoding,
    n_darks: usize,
    cfg: &PerPixelConfig,
) -> Result<Plan> {
    let per_px = frames * 3 * encoding.bytes();
    let side = cfg.tile.unwrap_or_else(|| {
        let s = ((TILE_TARGET_BYTES / per_px.max(1)) as f64).sqrt() as usize;
        // a multiple of 16 pixels, within the frame
        (s / 16 * 16).clamp(16, width.max(height).max(16))
    });
    let grid = TileGrid::new(width, height, cfg.block, side.max(cfg.block))?;
    let (tiles, rows) = match cfg.shard {
        None => (0..grid.n_tiles(), 0..grid.map_size().1),
        Some(s) => {
            if s.count > grid.tiles_y {
                return Err(Error::invalid(
                    "--shard",
                    format!(
                        "{}/{}: the frame has only {} rows of {} px tiles; use at most {} shards (or a smaller --tile)",
                        s.index, s.count, grid.tiles_y, grid.tile, grid.tiles_y
                    ),
                ));
            }
            let ty0 = s.index * grid.tiles_y / s.count;
            let ty1 = (s.index + 1) * grid.tiles_y / s.count;
            (
                ty0 * grid.tiles_x..ty1 * grid.tiles_x,
                grid.block_rows(ty0).start..grid.block_rows(ty1 - 1).end,
            )
        }
    };
    let (mw, mh) = grid.map_size();
    let store = TileStore::size_bytes(&grid, tiles.clone(), frames, encoding);
    let max_tile = tiles
        .clone()
        .map(|t| grid.tile_bytes(t, frames, encoding) as u128)
        .max()
        .unwrap_or(0);
    let px = (width * height) as u128;
    let dark = if n_darks > 0 {
        // the darks while averaged, then the tile-major copy
        px * (DECODE_BYTES_PER_PX + 13 * n_darks as u128)
    } else {
        0
    };
    let maps = (mw * rows.len()) as u128 * PixelMaps::BYTES_PER_BLOCK as u128;
    let write = (mw * mh) as u128 * WRITE_BYTES_PER_BLOCK;
    let peak = |in_flight: usize, in_memory: bool| {
        let st = if in_memory { store } else { 0 };
        let decode = st + in_flight as u128 * px * DECODE_BYTES_PER_PX + dark;
        let fit = st + maps + if in_memory { 0 } else { max_tile } + dark;
        let out = maps + write;
        BASE_BYTES + decode.max(fit).max(out)
    };
    let budget = u128::from(cfg.memory_mib) << 20;
    let threads = cfg.threads.max(1).min(frames.max(1));
    let mut choice = None;
    'outer: for in_memory in [true, false] {
        for in_flight in (1..=threads).rev() {
            if peak(in_flight, in_memory) <= budget {
                choice = Some((in_flight, in_memory));
                break 'outer;
            }
        }
    }
    let Some((in_flight, in_memory)) = choice else {
        return Err(Error::TooLarge {
            what: "--memory-gb".into(),
            requested: format!("{width}×{height} px × {frames} frames, block {}", cfg.block),
            needed_mib: (peak(1, false) >> 20) as u64,
            limit_mib: cfg.memory_mib,
            hint: "raise --memory-gb, fit in shards (--shard i/n), or use a larger --block".into(),
        });
    };
    let fit_units = tiles
        .clone()
        .map(|t| grid.rect(t).h.div_ceil(cfg.block) as u64)
        .sum();
    let storage_kind = if in_memory {
        Storage::Memory
    } else {
        Storage::ScratchFile(cfg.scratch_dir.clone())
    };
    Ok(Plan {
        frame_size: [width, height],
        frames,
        block: cfg.block,
        tile_px: grid.tile,
        tiles: grid.n_tiles(),
        tiles_held: [tiles.start, tiles.end],
        block_rows: [rows.start, rows.end],
        map_size: [mw, mh],
        encoding,
        storage: if in_memory {
            "memory".into()
        } else {
            format!("scratch file in {}", cfg.scratch_dir.display())
        },
        store_mib: mib(store),
        frames_in_flight: in_flight,
        peak_estimate_mib: mib(peak(in_flight, in_memory)),
        budget_mib: cfg.memory_mib,
        shard: cfg.shard,
        fit_units,
        storage_kind,
    })
}

/// Progress callbacks of [`fit_per_pixel`].
pub struct PerPixelHooks<'a> {
    /// Called once with the plan, before the store is allocated.
    pub planned: &'a dyn Fn(&Plan),
    /// Called once per decoded frame.
    pub decoded: &'a (dyn Fn() + Sync),
    /// Called once per fitted row of blocks (of a tile), from worker threads.
    pub fitted: &'a (dyn Fn() + Sync),
}

/// The result of [`fit_per_pixel`].
#[derive(Debug, Clone)]
pub struct PerPixelRun {
    /// The maps of the block rows fitted ([`Plan::block_rows`]).
    pub maps: PixelMaps,
    /// The plan followed.
    pub plan: Plan,
    /// Frame times and exposure factors, in time order.
    pub times: FrameTimes,
    /// Identity of the run's inputs and options (equal for every shard of one run).
    pub fingerprint: String,
    /// Seconds decoding frames into tiles.
    pub decode_s: f64,
    /// Seconds fitting.
    pub fit_s: f64,
    /// Warnings of the readers (once per distinct text).
    pub warnings: Vec<String>,
    /// Whether the first attempt's U16 encoding had to be given up for F32 (a frame off the
    /// 16-bit grid), so every frame was decoded twice.
    pub reencoded: bool,
}

struct Listed {
    file: PathBuf,
    row: Option<ManifestRow>,
}

fn list(series: &Path) -> Result<(Vec<Listed>, bool)> {
    if series.is_dir() {
        Ok((
            directory_frames(series)?
                .into_iter()
                .map(|file| Listed { file, row: None })
                .collect(),
            true,
        ))
    } else {
        let bytes = std::fs::read(series).map_err(|e| Error::io(series, e))?;
        let base = series.parent().unwrap_or(Path::new("."));
        Ok((
            parse_manifest(&bytes, &series.display().to_string(), base)?
                .into_iter()
                .map(|r| Listed {
                    file: r.file.clone(),
                    row: Some(r),
                })
                .collect(),
            false,
        ))
    }
}

/// Time in s (as listed, or the EXIF capture time for a folder) and exposure factor of a frame.
fn frame_time(info: &mut FrameInfo, l: &Listed) -> Result<(f64, f64)> {
    let exposure = resolve_exposure(info, l.row.as_ref())?;
    let t = crate::io::series::frame_time_s(info, l.row.as_ref())?;
    if !t.is_finite() {
        return Err(Error::invalid(
            "time_s",
            format!("{}: time {t} is not finite", info.file),
        ));
    }
    Ok((t, exposure.factor()))
}

/// Orders the frames by time (a folder) or checks the listed order (a manifest): times must
/// strictly increase, as [`crate::capture::PhotoSeries::new`] requires.
fn order_frames(t: &[f64], factor: &[f64], names: &[String], folder: bool) -> Result<FrameTimes> {
    let mut slot: Vec<usize> = (0..t.len()).collect();
    if folder {
        slot.sort_by(|a, b| t[*a].total_cmp(&t[*b]));
    }
    for w in slot.windows(2) {
        let (a, b) = (w[0], w[1]);
        if t[b] <= t[a] {
            let what = if t[b] == t[a] {
                "duplicated"
            } else {
                "decreasing"
            };
            return Err(Error::invalid(
                "time_s",
                format!(
                    "{what} times: {} at {} s follows {} at {} s; times must strictly increase",
                    names[b], t[b], names[a], t[a]
                ),
            ));
        }
    }
    let t0 = if folder { t[slot[0]] } else { 0.0 };
    Ok(FrameTimes {
        t_s: slot.iter().map(|&s| t[s] - t0).collect(),
        factor: slot.iter().map(|&s| factor[s]).collect(),
        slot,
    })
}

/// Whether a frame off the 16-bit grid ended a U16 attempt.
enum Attempt {
    Done(Box<PerPixelRun>),
    NeedsF32,
}

/// Fits the per-pixel maps of the series at `series` (a manifest CSV or a folder, as
/// [`crate::io::series::load_series`] reads it) within `cfg`'s memory budget: frames decoded
/// once into a tile store, blocks fitted tile by tile (see the module docs).
///
/// # Errors
/// The series' read errors (naming the file and line), sizes that differ, times that do not
/// increase, fewer than 3 frames, and the errors of [`plan`].
pub fn fit_per_pixel(
    series: &Path,
    opts: &DecayFitOptions,
    cfg: &PerPixelConfig,
    hooks: &PerPixelHooks<'_>,
) -> Result<PerPixelRun> {
    let (listed, folder) = list(series)?;
    if listed.len() < 3 {
        return Err(Error::invalid(
            "series",
            format!(
                "{}: {} frames; a decay fit needs at least 3",
                series.display(),
                listed.len()
            ),
        ));
    }
    match attempt(&listed, folder, opts, cfg, hooks, None)? {
        Attempt::Done(run) => Ok(*run),
        Attempt::NeedsF32 => {
            match attempt(&listed, folder, opts, cfg, hooks, Some(SampleEncoding::F32))? {
                Attempt::Done(mut run) => {
                    run.reencoded = true;
                    Ok(*run)
                }
                Attempt::NeedsF32 => Err(Error::invalid("series", "F32 tiles refused a frame")),
            }
        }
    }
}

fn attempt(
    listed: &[Listed],
    folder: bool,
    opts: &DecayFitOptions,
    cfg: &PerPixelConfig,
    hooks: &PerPixelHooks<'_>,
    forced: Option<SampleEncoding>,
) -> Result<Attempt> {
    let start = std::time::Instant::now();
    let n = listed.len();
    let mut store: Option<TileStore> = None;
    let mut plan_used: Option<Plan> = None;
    let (mut t, mut factor, mut names) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    let mut warnings: Vec<String> = Vec::new();
    let mut next = 0usize;
    let mut in_flight = cfg.threads.max(1);
    while next < n {
        let batch = &listed[next..(next + in_flight).min(n)];
        let decoded: Vec<Result<(RgbFrame, FrameInfo)>> = batch
            .par_iter()
            .map(|l| {
                let r = read_frame(&l.file);
                (hooks.decoded)();
                r
            })
            .collect();
        for (l, d) in batch.iter().zip(decoded) {
            let (frame, mut info) = d?;
            let (ts, k) = frame_time(&mut info, l)?;
            for w in info.warnings.drain(..) {
                if !warnings.contains(&w) {
                    warnings.push(w);
                }
            }
            if store.is_none() {
                let enc = forced.unwrap_or(if SampleEncoding::u16_lossless(&frame) {
                    SampleEncoding::U16
                } else {
                    SampleEncoding::F32
                });
                let p = plan(frame.width, frame.height, n, enc, cfg.darks.len(), cfg)?;
                (hooks.planned)(&p);
                let grid = TileGrid::new(frame.width, frame.height, cfg.block, p.tile_px)?;
                let tiles = p.tiles_held[0]..p.tiles_held[1];
                store = Some(TileStore::new(grid, tiles, n, enc, &p.storage_kind)?);
                in_flight = p.frames_in_flight;
                plan_used = Some(p);
            }
            let Some(st) = store.as_mut() else {
                return Err(Error::invalid("series", "no tile store"));
            };
            if st.encoding == SampleEncoding::U16 && !SampleEncoding::u16_lossless(&frame) {
                return Ok(Attempt::NeedsF32);
            }
            st.write_frame(t.len(), &frame)?;
            t.push(ts);
            factor.push(k);
            names.push(info.file.clone());
        }
        next += batch.len();
    }
    let (Some(mut store), Some(plan)) = (store, plan_used) else {
        return Err(Error::invalid("series", "no frames"));
    };
    if !cfg.darks.is_empty() {
        let darks = cfg
            .darks
            .iter()
            .map(|p| read_frame(p).map(|(f, _)| f))
            .collect::<Result<Vec<_>>>()?;
        let dark = RgbFrame::mean_of(&darks)?;
        store.set_dark(&dark).map_err(|_| {
            Error::invalid(
                "dark frame",
                format!(
                    "{} is {}×{} pixels but the series is {}×{}; a dark frame must be shot with the same camera and size",
                    dark.name, dark.width, dark.height, plan.frame_size[0], plan.frame_size[1]
                ),
            )
        })?;
    }
    let times = order_frames(&t, &factor, &names, folder)?;
    let decode_s = start.elapsed().as_secs_f64();
    let fingerprint = fingerprint(&names, &times, &plan, opts, &cfg.darks);
    let start = std::time::Instant::now();
    let grid = store.grid;
    let rows = plan.block_rows[0]..plan.block_rows[1];
    let mut maps = PixelMaps::failed(grid.map_size().0, rows.len(), cfg.block);
    let mut buf = Vec::new();
    for tile in store.tiles.clone() {
        let samples = store.tile(tile, &mut buf)?;
        let fits = fit_tile(&samples, &times, cfg.block, opts, hooks.fitted)?;
        place_tile(&mut maps, &grid, tile, rows.start, &fits);
    }
    drop(store);
    maps.recount();
    Ok(Attempt::Done(Box::new(PerPixelRun {
        maps,
        plan,
        times,
        fingerprint,
        decode_s,
        fit_s: start.elapsed().as_secs_f64(),
        warnings,
        reencoded: false,
    })))
}

/// SHA-256 over what makes two shards parts of one run: frame file names (not folders, so
/// nodes may mount the data elsewhere), times, exposure factors, frame size, block, the fit
/// options and the dark frames' names.
fn fingerprint(
    names: &[String],
    times: &FrameTimes,
    plan: &Plan,
    opts: &DecayFitOptions,
    darks: &[PathBuf],
) -> String {
    let base = |s: &str| {
        Path::new(s)
            .file_name()
            .map_or(s.to_string(), |f| f.to_string_lossy().to_string())
    };
    let mut text = format!(
        "size {:?} block {} options {:?}\n",
        plan.frame_size, plan.block, opts
    );
    for ((s, t), k) in times.slot.iter().zip(&times.t_s).zip(&times.factor) {
        text.push_str(&format!("{} {t:e} {k:e}\n", base(&names[*s])));
    }
    for d in darks {
        text.push_str(&format!("dark {}\n", base(&d.display().to_string())));
    }
    sha256_hex(text.as_bytes())
}

/// Schema of `shard.json`.
pub const SHARD_SCHEMA: &str = "lumifit.map-shard/1";
/// Name of a shard's manifest.
pub const SHARD_MANIFEST: &str = "shard.json";
/// Name of a shard's data file.
pub const SHARD_DATA: &str = "maps.f32le";

/// `shard.json`: what one shard of a per-pixel run holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShardManifest {
    /// [`SHARD_SCHEMA`].
    pub schema: String,
    /// Which shard.
    pub shard: Shard,
    /// The series as given on the command line (information only).
    pub series: String,
    /// [`PerPixelRun::fingerprint`].
    pub fingerprint: String,
    /// Frame size in pixels.
    pub frame_size: [usize; 2],
    /// Frames.
    pub frames: usize,
    /// Block side.
    pub block: usize,
    /// Full map size in blocks.
    pub map_size: [usize; 2],
    /// Block rows held (`[first, end)`).
    pub block_rows: [usize; 2],
    /// Plane names, in the order of the data file.
    pub planes: Vec<String>,
    /// The data file (beside the manifest).
    pub data: String,
    /// SHA-256 of the data file.
    pub data_sha256: String,
    /// Blocks fitted / failed in this shard.
    pub fitted: usize,
    /// Blocks that failed.
    pub failed: usize,
    /// Seconds decoding and fitting.
    pub seconds: f64,
    /// The plan the shard ran with.
    pub plan: serde_json::Value,
}

fn planes_bytes(maps: &PixelMaps) -> Vec<u8> {
    maps.planes()
        .iter()
        .flat_map(|p| p.iter().flat_map(|v| v.to_le_bytes()))
        .collect()
}

/// The files of a shard (`shard.json`, `maps.f32le`) as (name, bytes).
///
/// # Errors
/// [`Error::InvalidArgument`] when the run was not a shard.
pub fn shard_files(run: &PerPixelRun, series: &str) -> Result<Vec<(String, Vec<u8>)>> {
    let Some(shard) = cfg_shard(run) else {
        return Err(Error::invalid("--shard", "the run was not a shard"));
    };
    let data = planes_bytes(&run.maps);
    let manifest = ShardManifest {
        schema: SHARD_SCHEMA.into(),
        shard,
        series: series.into(),
        fingerprint: run.fingerprint.clone(),
        frame_size: run.plan.frame_size,
        frames: run.plan.frames,
        block: run.plan.block,
        map_size: run.plan.map_size,
        block_rows: run.plan.block_rows,
        planes: PLANE_NAMES.iter().map(|s| s.to_string()).collect(),
        data: SHARD_DATA.into(),
        data_sha256: sha256_hex(&data),
        fitted: run.maps.n_fitted,
        failed: run.maps.n_failed,
        seconds: run.decode_s + run.fit_s,
        plan: serde_json::to_value(&run.plan).unwrap_or_default(),
    };
    let text = serde_json::to_string_pretty(&manifest)
        .map_err(|e| Error::invalid("shard.json", e.to_string()))?;
    Ok(vec![
        (SHARD_MANIFEST.into(), text.into_bytes()),
        (SHARD_DATA.into(), data),
    ])
}

fn cfg_shard(run: &PerPixelRun) -> Option<Shard> {
    run.plan.shard
}

/// Merged shards: the full maps and what the shards said about themselves.
#[derive(Debug, Clone)]
pub struct MergedShards {
    /// The full maps.
    pub maps: PixelMaps,
    /// The shards' manifests, in shard order.
    pub manifests: Vec<ShardManifest>,
}

/// Reads the shards in `dirs` and merges them into the full maps (see the module docs).
///
/// # Errors
/// [`Error::InvalidArgument`] naming the shard's folder for a missing, duplicated, overlapping
/// or inconsistent shard or a data file whose size or SHA-256 does not match its manifest; the
/// read and JSON errors of the files.
pub fn merge_shards(dirs: &[PathBuf]) -> Result<MergedShards> {
    if dirs.is_empty() {
        return Err(Error::invalid("merge-maps", "no shard folders given"));
    }
    let mut shards: Vec<(PathBuf, ShardManifest)> = Vec::with_capacity(dirs.len());
    for d in dirs {
        let mp = d.join(SHARD_MANIFEST);
        let m: ShardManifest = crate::io::read_json(&mp)?;
        if m.schema != SHARD_SCHEMA {
            return Err(Error::invalid(
                mp.display().to_string(),
                format!("schema '{}'; expected '{SHARD_SCHEMA}'", m.schema),
            ));
        }
        if m.planes != PLANE_NAMES {
            return Err(Error::invalid(
                mp.display().to_string(),
                format!("planes {:?}; expected {:?}", m.planes, PLANE_NAMES),
            ));
        }
        shards.push((d.clone(), m));
    }
    let (d0, m0) = shards[0].clone();
    for (d, m) in &shards[1..] {
        let same = m.fingerprint == m0.fingerprint
            && m.shard.count == m0.shard.count
            && m.map_size == m0.map_size
            && m.block == m0.block
            && m.frame_size == m0.frame_size;
        if !same {
            return Err(Error::invalid(
                d.display().to_string(),
                format!(
                    "shard {}/{} is not part of the same run as {} (shard {}/{}): the series, its frames, the block or the fit options differ (fingerprint {} vs {})",
                    m.shard.index, m.shard.count, d0.display(), m0.shard.index, m0.shard.count,
                    &m.fingerprint[..12.min(m.fingerprint.len())], &m0.fingerprint[..12.min(m0.fingerprint.len())]
                ),
            ));
        }
    }
    shards.sort_by_key(|(_, m)| m.shard.index);
    for w in shards.windows(2) {
        if w[0].1.shard.index == w[1].1.shard.index {
            return Err(Error::invalid(
                w[1].0.display().to_string(),
                format!(
                    "shard {}/{} is given twice (also {})",
                    w[1].1.shard.index,
                    w[1].1.shard.count,
                    w[0].0.display()
                ),
            ));
        }
    }
    let count = m0.shard.count;
    let m0 = &m0;
    if let Some(missing) = (0..count).find(|i| !shards.iter().any(|(_, m)| m.shard.index == *i)) {
        return Err(Error::invalid(
            "merge-maps",
            format!(
                "shard {missing}/{count} is missing ({} of {count} shards given); every shard 0..{} is needed",
                shards.len(),
                count - 1
            ),
        ));
    }
    let [mw, mh] = m0.map_size;
    let mut row = 0usize;
    for (d, m) in &shards {
        if m.block_rows[0] != row || m.block_rows[1] < m.block_rows[0] || m.block_rows[1] > mh {
            return Err(Error::invalid(
                d.display().to_string(),
                format!(
                    "shard {}/{} holds block rows {}..{} but rows {row}.. follow the previous shard (of {mh}); the shards overlap or leave a gap",
                    m.shard.index, m.shard.count, m.block_rows[0], m.block_rows[1]
                ),
            ));
        }
        row = m.block_rows[1];
    }
    if row != mh {
        return Err(Error::invalid(
            "merge-maps",
            format!("the shards cover block rows 0..{row} of {mh}"),
        ));
    }
    let mut maps = PixelMaps::failed(mw, mh, m0.block);
    for (d, m) in &shards {
        let dp = d.join(&m.data);
        let bytes = std::fs::read(&dp).map_err(|e| Error::io(&dp, e))?;
        let rows = m.block_rows[1] - m.block_rows[0];
        let n = mw * rows;
        if bytes.len() != 4 * n * MAP_PLANES {
            return Err(Error::invalid(
                dp.display().to_string(),
                format!(
                    "{} bytes; shard {}/{} needs {} ({MAP_PLANES} planes of {mw}×{rows} f32)",
                    bytes.len(),
                    m.shard.index,
                    m.shard.count,
                    4 * n * MAP_PLANES
                ),
            ));
        }
        if sha256_hex(&bytes) != m.data_sha256 {
            return Err(Error::invalid(
                dp.display().to_string(),
                format!(
                    "SHA-256 differs from {} (the data file of shard {}/{} was truncated or modified)",
                    SHARD_MANIFEST, m.shard.index, m.shard.count
                ),
            ));
        }
        let off = m.block_rows[0] * mw;
        for (p, plane) in maps.planes_mut().into_iter().enumerate() {
            let src = &bytes[4 * n * p..4 * n * (p + 1)];
            for (i, c) in src.chunks_exact(4).enumerate() {
                plane[off + i] = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
            }
        }
    }
    maps.recount();
    Ok(MergedShards {
        maps,
        manifests: shards.into_iter().map(|(_, m)| m).collect(),
    })
}

/// Files to stage: (path relative to the output folder, bytes).
pub type NamedFiles = Vec<(String, Vec<u8>)>;

/// The peak resident set of this process in MiB (`VmHWM` of `/proc/self/status`; `None` where
/// there is no such file).
pub fn peak_rss_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// The summary of a per-pixel run or a merge (`summary.json`).
pub fn per_pixel_summary(
    series: &str,
    maps: &PixelMaps,
    frames: usize,
    frame_size: [usize; 2],
    files: &[String],
    timing: serde_json::Value,
    plan: serde_json::Value,
) -> serde_json::Value {
    let median = |v: &[f32]| -> Option<f64> {
        let mut x: Vec<f32> = v.iter().cloned().filter(|x| x.is_finite()).collect();
        if x.is_empty() {
            return None;
        }
        x.sort_by(f32::total_cmp);
        Some(f64::from(x[x.len() / 2]))
    };
    let mut hist = [0usize; 4];
    for n in &maps.n_states {
        hist[(*n as usize).min(3)] += 1;
    }
    serde_json::json!({
        "series": series,
        "frames": frames,
        "frame_size": frame_size,
        "block": maps.block,
        "map_size": [maps.width, maps.height],
        "blocks": maps.width * maps.height,
        "fitted": maps.n_fitted,
        "failed": maps.n_failed,
        "n_states_histogram": {"failed": hist[0], "1": hist[1], "2": hist[2], "3": hist[3]},
        "median": {
            "k1_per_s": median(&maps.k_per_s[0]), "k2_per_s": median(&maps.k_per_s[1]),
            "k3_per_s": median(&maps.k_per_s[2]), "rms": median(&maps.rms),
        },
        "timing": timing,
        "memory": plan,
        "maps": files,
        "format": "32-bit float TIFF, value repeated in R=G=B (spectrum_rgb.tif: r,g,b); NaN where a block could not be fitted; k1 is the fastest rate",
        "weights": "shot + read noise: sigma_t^2 = peak * (0.9 * max(max_c y_c(t), 0) + 0.1 * peak) per block",
    })
}

/// The files of `--materials` (see [`crate::phosphor::cluster`]): one preset per material
/// (`material_<k>.json`, RGB bands, Λ_i,c = a_i·S_c/k_i as `phos fit-decay` writes them), the
/// index map `materials.png` (8-bit grey when K ≤ 255, else 16-bit: 0 where the fit failed,
/// k for material k) and `materials.json` (the choice of K, errors, materials).
///
/// # Errors
/// The errors of [`crate::phosphor::cluster::cluster_materials`] and of the encoders.
pub fn material_files(
    maps: &PixelMaps,
    t_s: &[f64],
    count: crate::phosphor::cluster::MaterialCount,
    series: &Path,
    name: &str,
) -> Result<(NamedFiles, serde_json::Value)> {
    use crate::phosphor::cluster::{cluster_materials, MaterialCount};
    use crate::preset::{
        phosphor::provenance_of_files, to_json_string, Bands, MaterialPreset,
        PhosphorescenceSection, PhosphorescentState,
    };
    let m = cluster_materials(maps, t_s, count, 0x5eed)?;
    let mut files = Vec::new();
    let mut listed = Vec::new();
    for (j, mat) in m.materials.iter().enumerate() {
        let file = format!("material_{}.json", j + 1);
        let states: Vec<PhosphorescentState> = mat
            .k_per_s
            .iter()
            .zip(&mat.amplitude)
            .map(|(k, a)| {
                PhosphorescentState::new(*k, None, mat.spectrum.iter().map(|s| a * s / k).collect())
            })
            .collect();
        let lambda: Vec<f64> = states
            .iter()
            .flat_map(|s| s.lambda.iter().copied())
            .collect();
        crate::error::ensure_finite("a material's re-radiation functions", &file, &lambda)?;
        let provenance = provenance_of_files("lumifit phos fit-decay --per-pixel --materials", &[series])?
            .with_fit_quality(serde_json::json!({
                "material": j + 1, "materials": m.materials.len(), "blocks": mat.blocks,
                "reconstruction_error_median": m.chosen.median, "reconstruction_error_p95": m.chosen.p95,
            }));
        let mut preset = MaterialPreset::new(format!("{name} material {}", j + 1), provenance);
        let mut extra = serde_json::Map::new();
        extra.insert(
            "material_map".into(),
            serde_json::json!({
                "index_map": "materials.png", "index": j + 1,
                "meaning": "blocks of materials.png with this value are this material; Λ is at the material's median brightness (per-block brightness: the a1..a3 maps)",
                "k_per_s": mat.k_per_s, "amplitude": mat.amplitude, "spectrum_rgb": mat.spectrum,
            }),
        );
        preset.phosphorescence = Some(PhosphorescenceSection {
            bands: Bands::Rgb,
            states,
            extra,
        });
        files.push((file.clone(), to_json_string(&preset)?.into_bytes()));
        listed.push(serde_json::json!({
            "preset": file, "index": j + 1, "blocks": mat.blocks,
            "k_per_s": mat.k_per_s, "amplitude": mat.amplitude, "spectrum_rgb": mat.spectrum,
        }));
    }
    let (w, h) = (maps.width as u32, maps.height as u32);
    let png = if m.materials.len() <= 255 {
        let px: Vec<u8> = m.labels.iter().map(|l| *l as u8).collect();
        encode_png(w, h, &px, image::ExtendedColorType::L8)?
    } else {
        let px: Vec<u8> = m.labels.iter().flat_map(|l| l.to_ne_bytes()).collect();
        encode_png(w, h, &px, image::ExtendedColorType::L16)?
    };
    files.push(("materials.png".into(), png));
    let report = serde_json::json!({
        "materials": m.materials.len(),
        "choice": match count {
            MaterialCount::Auto { max, budget } => serde_json::json!({"mode": "auto", "max": max, "budget_p95": budget,
                "rule": "smallest K whose 95th-percentile relative reconstruction error (K-material model with one brightness per block, against the block's own fit, RMS over frames and channels / peak) is within the budget"}),
            MaterialCount::Fixed(k) => serde_json::json!({"mode": "fixed", "k": k}),
        },
        "reconstruction_error": m.chosen,
        "tried": m.tried,
        "errors_sampled_blocks": m.sampled,
        "index_map": "materials.png: 0 = fit failed, k = material k (material_k.json)",
        "list": listed,
    });
    files.push((
        "materials.json".into(),
        serde_json::to_string_pretty(&report)
            .map_err(|e| Error::invalid("materials.json", e.to_string()))?
            .into_bytes(),
    ));
    Ok((files, report))
}

fn encode_png(w: u32, h: u32, px: &[u8], ty: image::ExtendedColorType) -> Result<Vec<u8>> {
    use image::ImageEncoder;
    let mut out = std::io::Cursor::new(Vec::new());
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(px, w, h, ty)
        .map_err(|e| Error::invalid("PNG", format!("encoding failed: {e}")))?;
    Ok(out.into_inner())
}

/// Meaning and unit of each plane ([`PLANE_NAMES`] order), for the preset and the previews.
pub const PLANE_MEANING: [(&str, &str); MAP_PLANES] = [
    (
        "fastest decay rate k1 (NaN where the block has no state)",
        "1/s",
    ),
    (
        "second decay rate k2 (NaN where the block has fewer than 2 states)",
        "1/s",
    ),
    (
        "third decay rate k3 (NaN where the block has fewer than 3 states)",
        "1/s",
    ),
    (
        "amplitude a1 of state 1 at switch-off per unit spectrum",
        "relative radiance",
    ),
    (
        "amplitude a2 of state 2 at switch-off per unit spectrum",
        "relative radiance",
    ),
    (
        "amplitude a3 of state 3 at switch-off per unit spectrum",
        "relative radiance",
    ),
    (
        "shared emission spectrum, red channel (largest channel 1)",
        "",
    ),
    (
        "shared emission spectrum, green channel (largest channel 1)",
        "",
    ),
    (
        "shared emission spectrum, blue channel (largest channel 1)",
        "",
    ),
    ("number of states chosen (0 where the fit failed)", ""),
    ("residual RMS of the fit", "relative radiance"),
];

/// The renderer-facing files of a map set: a 16-bit PNG preview with a colour bar per plane
/// (`previews/<plane>.png`, [`crate::plot::maps`]) and `preset.json`, a material preset whose
/// phosphorescence section holds the median states (Λ_i,c = a_i·S_c/k_i over RGB bands) and
/// whose `maps` block references every map — texture path relative to the preset, preview, its
/// grey-level range, meaning and unit. `provenance_files` are hashed into the preset's
/// provenance. The preset is left out (and `None` returned as its name) when no block was fitted.
///
/// # Errors
/// Drawing, encoding and hashing errors.
pub fn map_extras(
    maps: &PixelMaps,
    name: &str,
    provenance_files: &[PathBuf],
) -> Result<(NamedFiles, Option<String>)> {
    use crate::plot::maps::{map_preview_png, MapPreview};
    use crate::preset::{
        phosphor::provenance_of_files, to_json_string, Bands, MaterialPreset,
        PhosphorescenceSection, PhosphorescentState,
    };
    let mut files = Vec::new();
    let mut refs = serde_json::Map::new();
    for (p, (plane, values)) in PLANE_NAMES.iter().zip(maps.planes()).enumerate() {
        let (meaning, unit) = PLANE_MEANING[p];
        let range = (*plane == "n_states").then_some((0.0, 3.0));
        let r = map_preview_png(&MapPreview {
            title: plane,
            unit,
            values,
            width: maps.width,
            height: maps.height,
            range,
        })?;
        let preview = format!("previews/{plane}.png");
        files.push((preview.clone(), r.png));
        refs.insert(
            (*plane).into(),
            serde_json::json!({
                "texture": format!("{plane}.tif"), "meaning": meaning, "unit": unit,
                "preview": preview, "preview_range": [r.range.0, r.range.1],
                "preview_scale": format!("grey v (16-bit) = {} + ({} - {})·v/65535; 1 preview px = {f}×{f} blocks", r.range.0, r.range.1, r.range.0, f = r.factor),
            }),
        );
    }
    refs.insert(
        "spectrum_rgb".into(),
        serde_json::json!({"texture": "spectrum_rgb.tif", "meaning": "shared emission spectrum r, g, b (largest channel 1)", "unit": ""}),
    );
    let median = |v: &[f32]| -> Option<f64> {
        let mut x: Vec<f32> = v.iter().cloned().filter(|x| x.is_finite()).collect();
        if x.is_empty() {
            return None;
        }
        x.sort_by(f32::total_cmp);
        Some(f64::from(x[x.len() / 2]))
    };
    let n_med = median(&maps.n_states).unwrap_or(0.0).round() as usize;
    let spectrum: Option<Vec<f64>> = (0..3).map(|c| median(&maps.spectrum[c])).collect();
    let states: Option<Vec<PhosphorescentState>> = (0..n_med
        .min(crate::phosphor::maps::MAP_STATES))
        .map(|i| {
            let (k, a) = (median(&maps.k_per_s[i])?, median(&maps.amplitude[i])?);
            let s = spectrum.as_ref()?;
            (k > 0.0)
                .then(|| PhosphorescentState::new(k, None, s.iter().map(|v| a * v / k).collect()))
        })
        .collect();
    let states = states.filter(|s| {
        !s.is_empty()
            && s.iter()
                .all(|st| st.lambda.iter().all(|l| l.is_finite() && *l >= 0.0))
    });
    let Some(states) = states else {
        return Ok((files, None));
    };
    let provenance = provenance_of_files("lumifit phos fit-decay --per-pixel", provenance_files)?
        .with_fit_quality(serde_json::json!({
            "blocks": maps.width * maps.height, "fitted": maps.n_fitted, "failed": maps.n_failed,
        }));
    let mut preset = MaterialPreset::new(name.to_string(), provenance);
    let mut extra = serde_json::Map::new();
    extra.insert(
        "maps".into(),
        serde_json::json!({
            "meaning": "per-block parameter maps of this material; the states above are the medians over the blocks (n_states = median number of states); a renderer that wants the spatial variation reads the textures",
            "paths": "relative to this preset",
            "format": "32-bit float TIFF, value repeated in R=G=B (spectrum_rgb.tif: r,g,b); NaN where a block could not be fitted",
            "size_blocks": [maps.width, maps.height], "block_px": maps.block,
            "emission": "L_c(x, t) = spectrum_c(x) * sum_i a_i(x) * exp(-k_i(x) * t), relative radiance after switch-off",
            "textures": refs,
        }),
    );
    preset.phosphorescence = Some(PhosphorescenceSection {
        bands: Bands::Rgb,
        states,
        extra,
    });
    files.push(("preset.json".into(), to_json_string(&preset)?.into_bytes()));
    Ok((files, Some("preset.json".into())))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(mem: u64) -> PerPixelConfig {
        PerPixelConfig {
            block: 1,
            tile: None,
            memory_mib: mem,
            scratch_dir: PathBuf::from("/tmp"),
            shard: None,
            darks: vec![],
            threads: 2,
        }
    }

    #[test]
    fn a_camera_series_goes_to_a_scratch_file_under_a_small_budget_and_to_memory_under_a_large_one()
    {
        let small = plan(6000, 4000, 37, SampleEncoding::U16, 0, &cfg(4096)).unwrap();
        assert!(small.storage.starts_with("scratch"), "{small:?}");
        assert!(small.peak_estimate_mib <= 4096.0);
        let large = plan(6000, 4000, 37, SampleEncoding::U16, 0, &cfg(16 * 1024)).unwrap();
        assert_eq!(large.storage, "memory");
        assert!(
            large.store_mib > 5000.0 && large.store_mib < 5100.0,
            "{}",
            large.store_mib
        );
        let e = plan(6000, 4000, 37, SampleEncoding::U16, 0, &cfg(512)).unwrap_err();
        assert!(e.to_string().contains("--memory-gb"), "{e}");
    }

    #[test]
    fn shards_split_the_tile_rows_without_overlap() {
        let mut c = cfg(4096);
        c.tile = Some(64);
        let mut next = 0;
        for i in 0..4 {
            c.shard = Some(Shard { index: i, count: 4 });
            let p = plan(300, 200, 10, SampleEncoding::U16, 0, &c).unwrap();
            assert_eq!(p.block_rows[0], next);
            next = p.block_rows[1];
        }
        assert_eq!(next, 200);
        c.shard = Some(Shard { index: 0, count: 5 });
        assert!(plan(300, 200, 10, SampleEncoding::U16, 0, &c).is_err());
        assert!(Shard::parse("4/4").is_err() && Shard::parse("x").is_err());
        assert_eq!(Shard::parse("1/4").unwrap(), Shard { index: 1, count: 4 });
    }
}
