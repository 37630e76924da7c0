//! One output path for every command: outputs are declared before any work, staged while the
//! command runs, and committed together only when everything succeeded.
//!
//! The rules (docs/conventions.md, "Outputs"):
//!
//! - Every input a command reads is registered with [`Outputs::input`]. An output whose path is
//!   the same file as an input — after canonicalisation, and also through a hard link — is refused
//!   by [`Outputs::declare`] with [`Error::OutputIsInput`] before any work starts.
//! - [`Outputs::stage`] writes the bytes at once to a temporary file (`.NAME.PID.N.tmp`) in the
//!   nearest existing ancestor directory of the target, so a large output does not stay in memory
//!   and a full disk is noticed early. Nothing is visible under the target's name yet.
//! - [`Outputs::commit`] creates missing parent directories, then renames every staged file into
//!   place. A command that fails before `commit` — or drops its `Outputs` — leaves every existing
//!   file byte-identical and removes its temporary files.
//! - The path `-` means standard output; what is staged for it is printed at commit.
//!
//! Missing output directories are created at commit time in every command (one rule), never
//! before the command has succeeded.

use std::collections::HashSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::error::{Error, Result};

static COUNTER: AtomicUsize = AtomicUsize::new(0);

/// A file's identity: canonical path, and (on Unix) device and inode so hard links compare equal.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
struct FileId {
    canonical: PathBuf,
    inode: Option<(u64, u64)>,
}

fn inode_of(path: &Path) -> Option<(u64, u64)> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        None
    }
}

/// The canonical form of a path that may not exist yet: the deepest existing ancestor is
/// canonicalised and the missing components are appended.
pub fn canonical_target(path: &Path) -> PathBuf {
    let abs = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir()
            .map(|d| d.join(path))
            .unwrap_or_else(|_| path.to_path_buf())
    };
    let mut existing = abs.clone();
    let mut rest: Vec<std::ffi::OsString> = Vec::new();
    loop {
        if let Ok(c) = existing.canonicalize() {
            let mut out = c;
            for part in rest.iter().rev() {
                out.push(part);
            }
            return out;
        }
        match (existing.file_name(), existing.parent()) {
            (Some(name), Some(parent)) => {
                rest.push(name.to_os_string());
                existing = parent.to_path_buf();
            }
            _ => return abs,
        }
    }
}

fn nearest_existing_dir(path: &Path) -> PathBuf {
    let mut dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    loop {
        if dir.is_dir() {
            return dir;
        }
        match dir.parent() {
            Some(p) if !p.as_os_str().is_empty() => dir = p.to_path_buf(),
            _ => return PathBuf::from("."),
        }
    }
}

#[derive(Debug)]
struct Staged {
    target: PathBuf,
    tmp: PathBuf,
}

/// The outputs of one command: declared, staged, then committed together.
#[derive(Debug, Default)]
pub struct Outputs {
    inputs: HashSet<FileId>,
    input_names: Vec<(FileId, PathBuf)>,
    declared: Vec<PathBuf>,
    staged: Vec<Staged>,
    stdout: Vec<u8>,
    committed: bool,
}

impl Outputs {
    /// An empty set: no inputs registered, nothing staged.
    pub fn new() -> Self {
        Self::default()
    }

    /// Registers a file the command reads (`-` for standard input is ignored). Call for every
    /// input before declaring outputs.
    pub fn input(&mut self, path: impl AsRef<Path>) -> &mut Self {
        let path = path.as_ref();
        if path.as_os_str() == "-" {
            return self;
        }
        let id = FileId {
            canonical: canonical_target(path),
            inode: inode_of(path),
        };
        self.input_names.push((id.clone(), path.to_path_buf()));
        self.inputs.insert(id);
        self
    }

    /// Registers several inputs.
    pub fn inputs<I, P>(&mut self, paths: I) -> &mut Self
    where
        I: IntoIterator<Item = P>,
        P: AsRef<Path>,
    {
        for p in paths {
            self.input(p);
        }
        self
    }

    fn same_as_input(&self, target: &Path) -> Option<&Path> {
        let canonical = canonical_target(target);
        let inode = inode_of(target);
        self.input_names
            .iter()
            .find(|(id, _)| id.canonical == canonical || (inode.is_some() && id.inode == inode))
            .map(|(_, p)| p.as_path())
    }

    /// Declares an output before any work: refused when it is one of the inputs, when it is an
    /// existing directory, or when it was declared twice. `flag` names the option in the error
    /// (e.g. `--out`).
    pub fn declare(&mut self, flag: &str, target: impl AsRef<Path>) -> Result<()> {
        let target = target.as_ref();
        if target.as_os_str() == "-" {
            return Ok(());
        }
        if target.as_os_str().is_empty() {
            return Err(Error::invalid(flag, "empty output path"));
        }
        if let Some(input) = self.same_as_input(target) {
            return Err(Error::OutputIsInput {
                flag: flag.to_string(),
                output: target.to_path_buf(),
                input: input.to_path_buf(),
            });
        }
        if target.is_dir() {
            return Err(Error::invalid(
                flag,
                format!(
                    "'{}' is a directory; expected a file path",
                    target.display()
                ),
            ));
        }
        let canonical = canonical_target(target);
        if self.declared.contains(&canonical) {
            return Err(Error::invalid(
                flag,
                format!(
                    "'{}' is named as two different outputs of this command",
                    target.display()
                ),
            ));
        }
        self.declared.push(canonical);
        Ok(())
    }

    /// Declares an output directory (`--out DIR/`): refused when it is an existing file or one
    /// of the inputs. Files staged below it are checked again by [`Outputs::stage`].
    pub fn declare_dir(&mut self, flag: &str, dir: impl AsRef<Path>) -> Result<()> {
        let dir = dir.as_ref();
        if dir.exists() && !dir.is_dir() {
            return Err(Error::invalid(
                flag,
                format!(
                    "'{}' exists and is not a directory; expected an output directory",
                    dir.display()
                ),
            ));
        }
        if let Some(input) = self.same_as_input(dir) {
            return Err(Error::OutputIsInput {
                flag: flag.to_string(),
                output: dir.to_path_buf(),
                input: input.to_path_buf(),
            });
        }
        Ok(())
    }

    /// Stages `bytes` for `target` (`-`: standard output). The bytes go to a temporary file now;
    /// the target appears only at [`Outputs::commit`]. A target that is an input is refused even
    /// if it was not declared.
    pub fn stage(&mut self, target: impl AsRef<Path>, bytes: &[u8]) -> Result<()> {
        let target = target.as_ref();
        if target.as_os_str() == "-" {
            self.stdout.extend_from_slice(bytes);
            return Ok(());
        }
        if let Some(input) = self.same_as_input(target) {
            return Err(Error::OutputIsInput {
                flag: "output".to_string(),
                output: target.to_path_buf(),
                input: input.to_path_buf(),
            });
        }
        if target.is_dir() {
            return Err(Error::io(
                target,
                std::io::Error::new(
                    std::io::ErrorKind::IsADirectory,
                    "is a directory; expected a file path",
                ),
            ));
        }
        if let Some(i) = self.staged.iter().position(|s| s.target == target) {
            let old = self.staged.remove(i);
            let _ = std::fs::remove_file(&old.tmp);
        }
        let dir = nearest_existing_dir(target);
        let name = target
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "output".into());
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp = dir.join(format!(".{name}.{}.{n}.tmp", std::process::id()));
        let written = (|| -> std::io::Result<()> {
            let mut f = std::fs::File::create(&tmp)?;
            f.write_all(bytes)?;
            f.sync_all()
        })();
        if let Err(e) = written {
            let _ = std::fs::remove_file(&tmp);
            return Err(Error::io(target, e));
        }
        self.staged.push(Staged {
            target: target.to_path_buf(),
            tmp,
        });
        Ok(())
    }

    /// Stages UTF-8 text (see [`Outputs::stage`]).
    pub fn stage_text(&mut self, target: impl AsRef<Path>, text: &str) -> Result<()> {
        self.stage(target, text.as_bytes())
    }

    /// Paths staged so far (not `-`).
    pub fn staged_paths(&self) -> Vec<&Path> {
        self.staged.iter().map(|s| s.target.as_path()).collect()
    }

    /// Creates missing directories, renames every staged file into place and prints what was
    /// staged for standard output. Returns the paths written.
    pub fn commit(mut self) -> Result<Vec<PathBuf>> {
        for s in &self.staged {
            if let Some(parent) = s.target.parent() {
                if !parent.as_os_str().is_empty() && !parent.is_dir() {
                    std::fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))?;
                }
            }
        }
        let mut written = Vec::with_capacity(self.staged.len());
        let staged = std::mem::take(&mut self.staged);
        let mut failure = None;
        for (i, s) in staged.iter().enumerate() {
            // The temporary file may sit in an ancestor directory; rename works within one
            // file system, otherwise copy then remove.
            let moved = std::fs::rename(&s.tmp, &s.target).or_else(|_| {
                std::fs::copy(&s.tmp, &s.target).and_then(|_| std::fs::remove_file(&s.tmp))
            });
            if let Err(e) = moved {
                failure = Some((i, Error::io(&s.target, e)));
                break;
            }
            written.push(s.target.clone());
        }
        if let Some((i, e)) = failure {
            for s in &staged[i..] {
                let _ = std::fs::remove_file(&s.tmp);
            }
            self.committed = true;
            return Err(e);
        }
        self.committed = true;
        if !self.stdout.is_empty() {
            let mut out = std::io::stdout().lock();
            match out.write_all(&self.stdout).and_then(|_| out.flush()) {
                Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
                Err(e) => return Err(Error::io("<stdout>", e)),
                Ok(()) => {}
            }
        }
        Ok(written)
    }
}

impl Drop for Outputs {
    fn drop(&mut self) {
        if !self.committed {
            for s in &self.staged {
                let _ = std::fs::remove_file(&s.tmp);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_equal_to_an_input_is_refused_before_work() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("c.csv");
        std::fs::write(&input, b"keep").unwrap();
        let mut out = Outputs::new();
        out.input(&input);
        let alias = dir.path().join(".").join("c.csv");
        let e = out.declare("--out", &alias).unwrap_err();
        assert!(matches!(e, Error::OutputIsInput { .. }), "{e}");
        assert_eq!(std::fs::read(&input).unwrap(), b"keep");
    }

    #[test]
    fn a_hard_link_to_an_input_is_the_input() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("a.json");
        std::fs::write(&input, b"keep").unwrap();
        let link = dir.path().join("b.json");
        std::fs::hard_link(&input, &link).unwrap();
        let mut out = Outputs::new();
        out.input(&input);
        assert!(out.declare("--out", &link).is_err());
    }

    #[test]
    fn nothing_appears_until_commit_and_a_dropped_set_leaves_no_trace() {
        let dir = tempfile::tempdir().unwrap();
        let keep = dir.path().join("keep.json");
        std::fs::write(&keep, b"old").unwrap();
        {
            let mut out = Outputs::new();
            out.declare("--out", &keep).unwrap();
            out.stage(&keep, b"new").unwrap();
            assert_eq!(std::fs::read(&keep).unwrap(), b"old");
            // dropped without commit: the late failure of a command
        }
        assert_eq!(std::fs::read(&keep).unwrap(), b"old");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1, "temporary files left behind");
    }

    #[test]
    fn commit_creates_missing_directories_and_writes_every_file() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("new/sub/a.csv");
        let b = dir.path().join("b.png");
        let mut out = Outputs::new();
        out.declare("--out", &a).unwrap();
        out.declare("--plot", &b).unwrap();
        out.stage(&a, b"1").unwrap();
        out.stage(&b, b"2").unwrap();
        assert!(
            !dir.path().join("new").exists(),
            "directory created before commit"
        );
        let written = out.commit().unwrap();
        assert_eq!(written.len(), 2);
        assert_eq!(std::fs::read(&a).unwrap(), b"1");
        assert_eq!(std::fs::read(&b).unwrap(), b"2");
    }

    #[test]
    fn the_same_output_declared_twice_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.csv");
        let mut out = Outputs::new();
        out.declare("--out", &a).unwrap();
        assert!(out.declare("--summary", &a).is_err());
    }

    #[test]
    fn an_output_directory_that_is_a_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("f");
        std::fs::write(&f, b"x").unwrap();
        let mut out = Outputs::new();
        assert!(out.declare_dir("--images", &f).is_err());
    }
}
