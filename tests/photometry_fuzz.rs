//! Fuzzing the IES and EULUMDAT readers in-process: a proptest-style generator (xorshift, no
//! extra dependencies) mutates each of the real files of `../shared/data/photometric/` (when
//! present) and lumifit's synthetic profiles written by both writers — 10⁵ mutated files in
//! total: byte flips, line drops, line duplications, number swaps, nasty numbers, truncation.
//! Every one must return Ok, or an `Error::Parse` naming the file and a line (what the CLI shows
//! with exit code 2); a panic or another error kind fails.

use std::path::PathBuf;

use lumifit::io::eulumdat::{parse_ldt, write_ldt};
use lumifit::io::ies::{parse_ies, write_ies};
use lumifit::photometry::synthetic::SyntheticProfile;
use lumifit::Error;

/// Mutated files in total over all bases.
const MUTATIONS: usize = 100_000;

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.0 = x;
        x
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// As `read_ies` does for a TILT=<file> that is not there: an I/O error naming that file.
fn no_tilt(name: &str) -> lumifit::Result<(Vec<u8>, String)> {
    Err(Error::io(
        name,
        std::io::Error::new(
            std::io::ErrorKind::NotFound,
            "no TILT files in the fuzz test",
        ),
    ))
}

/// Byte ranges of the numeric tokens of `b`.
fn numbers(b: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_digit() || b[i] == b'-' || b[i] == b'.' {
            let s = i;
            while i < b.len()
                && (b[i].is_ascii_alphanumeric() || b[i] == b'-' || b[i] == b'.' || b[i] == b'+')
            {
                i += 1;
            }
            out.push((s, i));
        } else {
            i += 1;
        }
    }
    out
}

fn line_starts(b: &[u8]) -> Vec<usize> {
    std::iter::once(0)
        .chain(
            b.iter()
                .enumerate()
                .filter(|(_, &c)| c == b'\n')
                .map(|(i, _)| i + 1),
        )
        .filter(|&i| i < b.len())
        .collect()
}

fn mutate(base: &[u8], nums: &[(usize, usize)], rng: &mut Rng) -> Vec<u8> {
    const ALPHABET: &[u8] = b"0123456789-.eE ,\n\r\t[]TILT=NONE+\xef\xbb\xbf\x00";
    const NASTY: [&str; 12] = [
        "-1",
        "0",
        "1e308",
        "-1e308",
        "nan",
        "inf",
        "99999999999",
        "3",
        "360",
        "-90",
        "0.0.0",
        "",
    ];
    let mut m = base.to_vec();
    for _ in 0..1 + rng.below(4) {
        if m.is_empty() {
            break;
        }
        match rng.below(7) {
            0 => {
                let i = rng.below(m.len());
                m[i] = ALPHABET[rng.below(ALPHABET.len())];
            }
            1 => {
                // drop a line
                let starts = line_starts(&m);
                let k = rng.below(starts.len());
                let end = starts.get(k + 1).copied().unwrap_or(m.len());
                m.drain(starts[k]..end);
            }
            2 => {
                // duplicate a line
                let starts = line_starts(&m);
                let k = rng.below(starts.len());
                let end = starts.get(k + 1).copied().unwrap_or(m.len());
                let line = m[starts[k]..end].to_vec();
                m.splice(starts[k]..starts[k], line);
            }
            3 | 4 if !nums.is_empty() && m.len() == base.len() => {
                // swap two numbers of the (so far unchanged-length) file, or put in a nasty one
                let (a0, a1) = nums[rng.below(nums.len())];
                if rng.below(2) == 0 {
                    let (b0, b1) = nums[rng.below(nums.len())];
                    let (x, y) = (m[a0..a1].to_vec(), m[b0..b1].to_vec());
                    if a1 <= b0 {
                        m.splice(b0..b1, x);
                        m.splice(a0..a1, y);
                    } else if b1 <= a0 {
                        m.splice(a0..a1, y);
                        m.splice(b0..b1, x);
                    }
                } else {
                    let v = NASTY[rng.below(NASTY.len())];
                    m.splice(a0..a1, v.bytes());
                }
            }
            5 => {
                let i = rng.below(m.len());
                m.truncate(i);
            }
            _ => {
                let i = rng.below(m.len());
                m.remove(i);
            }
        }
    }
    m
}

fn data_files() -> Vec<PathBuf> {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data/photometric");
    if !d.is_dir() {
        if std::env::var("LUMIFIT_REQUIRE_DATA").as_deref() == Ok("1") {
            panic!("LUMIFIT_REQUIRE_DATA=1 but {} is absent", d.display());
        }
        eprintln!(
            "skipping the real files: {} is absent (set LUMIFIT_REQUIRE_DATA=1 to make this a failure); fuzzing the synthetic ones only",
            d.display()
        );
        return Vec::new();
    }
    let mut out = Vec::new();
    for sub in std::fs::read_dir(&d).unwrap() {
        let sub = sub.unwrap().path();
        if sub.is_dir() {
            for f in std::fs::read_dir(&sub).unwrap() {
                let f = f.unwrap().path();
                let ext = f
                    .extension()
                    .map(|e| e.to_string_lossy().to_ascii_lowercase())
                    .unwrap_or_default();
                if ext == "ies" || ext == "ldt" {
                    out.push(f);
                }
            }
        }
    }
    out.sort();
    out
}

#[test]
fn a_hundred_thousand_mutated_files_never_panic_and_every_error_names_file_and_line() {
    // (name, is_ies, bytes)
    let mut bases: Vec<(String, bool, Vec<u8>)> = Vec::new();
    let real = data_files();
    if std::env::var("LUMIFIT_REQUIRE_DATA").as_deref() == Ok("1") {
        assert_eq!(real.len(), 15, "expected the 15 files of the data folder");
    }
    for f in &real {
        let ies = f.extension().is_some_and(|e| e.eq_ignore_ascii_case("ies"));
        let name = f.file_name().unwrap().to_string_lossy().to_string();
        bases.push((name, ies, std::fs::read(f).unwrap()));
    }
    for p in SyntheticProfile::ALL {
        let file = p.file().unwrap();
        let ies = write_ies(&file, "fuzz").unwrap();
        let ldt = write_ldt(&file, "fuzz").unwrap();
        bases.push((format!("{}.ies", p.name()), true, ies.into_bytes()));
        bases.push((format!("{}.ldt", p.name()), false, ldt.into_bytes()));
    }
    // every base is good before it is mutated
    for (name, ies, b) in &bases {
        let r = if *ies {
            parse_ies(b, name, &no_tilt, 0.0).map(|_| ())
        } else {
            parse_ldt(b, name).map(|_| ())
        };
        assert!(r.is_ok(), "{name}: {r:?}");
    }
    let nums: Vec<Vec<(usize, usize)>> = bases.iter().map(|b| numbers(&b.2)).collect();
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let (mut ok, mut refused) = (0usize, 0usize);
    // small files more often than large ones, so the run stays a few seconds: each base gets
    // a share ∝ min(10, 8 kB / its size), at least 1
    let schedule: Vec<usize> = bases
        .iter()
        .enumerate()
        .flat_map(|(k, b)| std::iter::repeat_n(k, (8000 / b.2.len().max(1)).clamp(1, 10)))
        .collect();
    for round in 0..MUTATIONS {
        let k = schedule[round % schedule.len()];
        let (name, ies, base) = &bases[k];
        let m = mutate(base, &nums[k], &mut rng);
        let r = std::panic::catch_unwind(|| {
            if *ies {
                parse_ies(&m, name, &no_tilt, 0.0).map(|_| ())
            } else {
                parse_ldt(&m, name).map(|_| ())
            }
        });
        let r = r.unwrap_or_else(|_| {
            panic!(
                "panic on mutation {round} of {name}: {:?}",
                String::from_utf8_lossy(&m)
            )
        });
        match r {
            Ok(()) => ok += 1,
            Err(Error::Parse {
                file,
                line,
                message,
            }) => {
                assert_eq!(&file, name, "mutation {round}: {message}");
                assert!(
                    line >= 1
                        || m.iter().all(|c| c.is_ascii_whitespace())
                        || message.contains("whole file")
                        || message.contains("empty")
                        || message.contains("end of file")
                        || message.contains("binary"),
                    "mutation {round} of {name}: line 0 for '{message}'"
                );
                assert!(!message.is_empty());
                refused += 1;
            }
            // a mutated TILT=NONE that became TILT=<name>: the missing file is named
            Err(Error::Io { path, .. }) if !path.as_os_str().is_empty() => refused += 1,
            Err(e) => panic!(
                "mutation {round} of {name}: not a parse error naming file and line: {e:?}\n{:?}",
                String::from_utf8_lossy(&m)
            ),
        }
    }
    eprintln!(
        "{MUTATIONS} mutations of {} files ({} real): {ok} read, {refused} refused with file and line",
        bases.len(),
        real.len()
    );
    assert!(
        refused > MUTATIONS / 4 && ok > MUTATIONS / 100,
        "{ok} read, {refused} refused"
    );
}
