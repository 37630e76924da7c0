//! Captured frames, regions of interest and photo series in memory (no file system).
