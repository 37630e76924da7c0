//! Tile-major storage of a photo series' pixels for per-pixel fits at camera resolution
//! (`phos fit-decay --per-pixel`): every frame is decoded once and scattered into tiles
//! ([`crate::phosphor::maps::TileGrid`]), so that one tile's curves are one contiguous run of
//! bytes, read back tile by tile while fitting.
//!
//! The bytes live in memory when they fit the memory budget, else in a scratch file. The file
//! is written and read with positional I/O (`pwrite`/`pread`), not memory-mapped: pages of a
//! mapped file count in the process's resident set, and with free memory the kernel keeps them
//! there, so a 5 GB mapping would push the peak RSS past a `--memory-gb 4` limit; positional I/O
//! goes through the page cache, which the kernel drops on demand and which is not the process's
//! memory. The file is deleted as soon as it is opened (Unix), so it disappears with the process
//! even after a crash; elsewhere it is deleted when the store is dropped.
//!
//! Layout: tile *t* starts at `offset[t]`; within it, slot *j* (a frame, in decoding order)
//! holds the tile's `w × h` pixels row-major, three channels, in the store's
//! [`SampleEncoding`]. A dark frame, when given, is kept in memory tile-major as F32.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::capture::RgbFrame;
use crate::error::{Error, Result};
use crate::phosphor::maps::{encode_tile, SampleEncoding, TileGrid, TileSamples};

static COUNTER: AtomicUsize = AtomicUsize::new(0);

#[derive(Debug)]
enum Backing {
    Memory(Vec<u8>),
    File { file: File, path: PathBuf },
}

/// Where a [`TileStore`] keeps its bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Storage {
    /// In memory.
    Memory,
    /// In a scratch file in this folder.
    ScratchFile(PathBuf),
}

/// The pixels of tiles `tiles` of a series, tile-major (see the module docs).
#[derive(Debug)]
pub struct TileStore {
    /// The tiles.
    pub grid: TileGrid,
    /// Encoding of the samples.
    pub encoding: SampleEncoding,
    /// Frames (slots) per tile.
    pub frames: usize,
    /// The tiles held (a shard holds a range).
    pub tiles: std::ops::Range<usize>,
    offsets: Vec<u64>,
    backing: Backing,
    dark: Option<Vec<u8>>,
    dark_offsets: Vec<usize>,
    buf: Vec<u8>,
}

impl TileStore {
    /// Total bytes of the samples of `tiles` of `grid` for `frames` frames in `enc`.
    pub fn size_bytes(
        grid: &TileGrid,
        tiles: std::ops::Range<usize>,
        frames: usize,
        enc: SampleEncoding,
    ) -> u128 {
        tiles.map(|t| grid.tile_bytes(t, frames, enc) as u128).sum()
    }

    /// An empty store of `tiles` of `grid` for `frames` frames, in memory or in a scratch file
    /// in the given folder (created if missing).
    ///
    /// # Errors
    /// [`Error::Io`] naming the scratch file when it cannot be created or sized;
    /// [`Error::InvalidArgument`] for an empty tile range.
    pub fn new(
        grid: TileGrid,
        tiles: std::ops::Range<usize>,
        frames: usize,
        encoding: SampleEncoding,
        storage: &Storage,
    ) -> Result<Self> {
        if tiles.is_empty() || tiles.end > grid.n_tiles() {
            return Err(Error::invalid(
                "tiles",
                format!(
                    "{tiles:?}; expected a non-empty range within 0..{}",
                    grid.n_tiles()
                ),
            ));
        }
        let mut offsets = Vec::with_capacity(tiles.len());
        let mut total = 0u64;
        for t in tiles.clone() {
            offsets.push(total);
            total += grid.tile_bytes(t, frames, encoding) as u64;
        }
        let backing = match storage {
            Storage::Memory => {
                let len = usize::try_from(total)
                    .map_err(|_| Error::invalid("tiles", "too large for this machine's memory"))?;
                Backing::Memory(vec![0u8; len])
            }
            Storage::ScratchFile(dir) => {
                std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
                let n = COUNTER.fetch_add(1, Ordering::Relaxed);
                let path = dir.join(format!(".lumifit-tiles.{}.{n}.bin", std::process::id()));
                let file = std::fs::OpenOptions::new()
                    .read(true)
                    .write(true)
                    .create_new(true)
                    .open(&path)
                    .map_err(|e| Error::io(&path, e))?;
                file.set_len(total).map_err(|e| Error::io(&path, e))?;
                #[cfg(unix)]
                let _ = std::fs::remove_file(&path);
                Backing::File { file, path }
            }
        };
        Ok(Self {
            grid,
            encoding,
            frames,
            tiles,
            offsets,
            backing,
            dark: None,
            dark_offsets: Vec::new(),
            buf: Vec::new(),
        })
    }

    /// Where the bytes are (`None` in memory; the scratch file's path otherwise).
    pub fn scratch_path(&self) -> Option<&Path> {
        match &self.backing {
            Backing::Memory(_) => None,
            Backing::File { path, .. } => Some(path),
        }
    }

    /// Bytes held.
    pub fn len_bytes(&self) -> u64 {
        self.tiles
            .clone()
            .map(|t| self.grid.tile_bytes(t, self.frames, self.encoding) as u64)
            .sum()
    }

    fn check_frame(&self, frame: &RgbFrame) -> Result<()> {
        if (frame.width, frame.height) != (self.grid.width, self.grid.height) {
            return Err(Error::invalid(
                "series",
                format!(
                    "{} is {}×{} pixels but the series is {}×{}; all frames of a series must have the same size",
                    frame.name, frame.width, frame.height, self.grid.width, self.grid.height
                ),
            ));
        }
        Ok(())
    }

    /// Scatters `frame` into slot `slot` of every tile held.
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for a frame of another size or a slot out of range;
    /// [`Error::Io`] naming the scratch file when a write fails (e.g. the disk is full).
    pub fn write_frame(&mut self, slot: usize, frame: &RgbFrame) -> Result<()> {
        self.check_frame(frame)?;
        if slot >= self.frames {
            return Err(Error::invalid(
                "slot",
                format!("{slot}; the store holds {} frames", self.frames),
            ));
        }
        for (k, t) in self.tiles.clone().enumerate() {
            let r = self.grid.rect(t);
            let chunk = r.w * r.h * 3 * self.encoding.bytes();
            let at = self.offsets[k] + (slot * chunk) as u64;
            self.buf.clear();
            encode_tile(frame, r, self.encoding, &mut self.buf);
            match &mut self.backing {
                Backing::Memory(v) => {
                    let at = at as usize;
                    v[at..at + chunk].copy_from_slice(&self.buf);
                }
                Backing::File { file, path } => write_at(file, &self.buf, at).map_err(|e| {
                    Error::io(
                        path.clone(),
                        std::io::Error::new(
                            e.kind(),
                            format!("writing the tile scratch file failed ({e}); free disk space or choose another folder with --scratch-dir"),
                        ),
                    )
                })?,
            }
        }
        Ok(())
    }

    /// Keeps `dark` (subtracted from every sample when the tiles are read).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for a dark frame of another size.
    pub fn set_dark(&mut self, dark: &RgbFrame) -> Result<()> {
        self.check_frame(dark)?;
        let mut bytes = Vec::new();
        let mut offsets = Vec::with_capacity(self.tiles.len());
        for t in self.tiles.clone() {
            offsets.push(bytes.len());
            encode_tile(dark, self.grid.rect(t), SampleEncoding::F32, &mut bytes);
        }
        self.dark = Some(bytes);
        self.dark_offsets = offsets;
        Ok(())
    }

    /// The samples of tile `t` (read into `buf` when the store is a file).
    ///
    /// # Errors
    /// [`Error::InvalidArgument`] for a tile not held; [`Error::Io`] when reading fails.
    pub fn tile<'a>(&'a self, t: usize, buf: &'a mut Vec<u8>) -> Result<TileSamples<'a>> {
        if !self.tiles.contains(&t) {
            return Err(Error::invalid(
                "tile",
                format!("{t}; the store holds tiles {:?}", self.tiles),
            ));
        }
        let k = t - self.tiles.start;
        let rect = self.grid.rect(t);
        let len = self.grid.tile_bytes(t, self.frames, self.encoding);
        let at = self.offsets[k];
        let bytes: &[u8] = match &self.backing {
            Backing::Memory(v) => &v[at as usize..at as usize + len],
            Backing::File { file, path } => {
                buf.resize(len, 0);
                read_at(file, buf, at).map_err(|e| Error::io(path.clone(), e))?;
                buf
            }
        };
        let dark = self.dark.as_ref().map(|d| {
            let o = self.dark_offsets[k];
            &d[o..o + 12 * rect.w * rect.h]
        });
        Ok(TileSamples {
            rect,
            encoding: self.encoding,
            frames: self.frames,
            bytes,
            dark,
        })
    }
}

impl Drop for TileStore {
    fn drop(&mut self) {
        if let Backing::File { path, .. } = &self.backing {
            // already unlinked on Unix; elsewhere the file goes now
            let _ = std::fs::remove_file(path);
        }
    }
}

#[cfg(unix)]
fn write_at(file: &File, bytes: &[u8], at: u64) -> std::io::Result<()> {
    use std::os::unix::fs::FileExt;
    file.write_all_at(bytes, at)
}

#[cfg(unix)]
fn read_at(file: &File, bytes: &mut [u8], at: u64) -> std::io::Result<()> {
    use std::os::unix::fs::FileExt;
    file.read_exact_at(bytes, at)
}

#[cfg(windows)]
fn write_at(file: &File, mut bytes: &[u8], mut at: u64) -> std::io::Result<()> {
    use std::os::windows::fs::FileExt;
    while !bytes.is_empty() {
        let n = file.seek_write(bytes, at)?;
        if n == 0 {
            return Err(std::io::ErrorKind::WriteZero.into());
        }
        bytes = &bytes[n..];
        at += n as u64;
    }
    Ok(())
}

#[cfg(windows)]
fn read_at(file: &File, mut bytes: &mut [u8], mut at: u64) -> std::io::Result<()> {
    use std::os::windows::fs::FileExt;
    while !bytes.is_empty() {
        let n = file.seek_read(bytes, at)?;
        if n == 0 {
            return Err(std::io::ErrorKind::UnexpectedEof.into());
        }
        bytes = &mut bytes[n..];
        at += n as u64;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(w: usize, h: usize, seed: u32) -> RgbFrame {
        let data: Vec<f32> = (0..3 * w * h)
            .map(|i| f32::from(((i as u32 * 7919 + seed) % 60000) as u16) / 65535.0)
            .collect();
        RgbFrame::new("f", w, h, 1, data, vec![0; w * h]).unwrap()
    }

    #[test]
    fn a_scratch_file_store_reads_back_what_the_memory_store_holds() {
        let d = tempfile::tempdir().unwrap();
        let grid = TileGrid::new(9, 7, 2, 4).unwrap();
        let frames: Vec<RgbFrame> = (0..3).map(|s| frame(9, 7, s)).collect();
        let mut mem = TileStore::new(
            grid,
            1..grid.n_tiles(),
            3,
            SampleEncoding::U16,
            &Storage::Memory,
        )
        .unwrap();
        let mut file = TileStore::new(
            grid,
            1..grid.n_tiles(),
            3,
            SampleEncoding::U16,
            &Storage::ScratchFile(d.path().to_path_buf()),
        )
        .unwrap();
        for (j, f) in frames.iter().enumerate() {
            mem.write_frame(j, f).unwrap();
            file.write_frame(j, f).unwrap();
        }
        mem.set_dark(&frames[0]).unwrap();
        file.set_dark(&frames[0]).unwrap();
        let (mut b1, mut b2) = (Vec::new(), Vec::new());
        for t in 1..grid.n_tiles() {
            let a = mem.tile(t, &mut b1).unwrap();
            let b = file.tile(t, &mut b2).unwrap();
            assert_eq!(a.bytes, b.bytes, "tile {t}");
            assert_eq!(a.dark, b.dark);
        }
        assert!(mem.tile(0, &mut b1).is_err());
        // on Unix the scratch file is unlinked at once: nothing is left in the folder
        #[cfg(unix)]
        assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0);
        let other = frame(8, 7, 0);
        assert!(file.write_frame(0, &other).is_err());
    }
}
