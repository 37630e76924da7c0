//! The Jiang et al. 2013 camera database, read in place from `../shared/data/camera/`: a skip
//! message when it is absent, a failure when `LUMIFIT_REQUIRE_DATA=1`.

use std::path::PathBuf;

use lumifit::io::camera::parse_camera_database;
use lumifit::spectrum::MultiSpectrum;

/// File name of the long-format table (`camera,wavelength_nm,r,g,b`).
pub const DATABASE: &str = "jiang2013_camspec_all_cameras_long.csv";

/// The three cameras the LVF tests run over.
pub const CAMERAS: [&str; 3] = ["Canon 5DMarkII", "Nikon D700", "SONY NEX-5N"];

/// Where the long-format table is (`../shared/data/camera/`, read in place).
pub fn path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/camera")
        .join(DATABASE)
}

/// The database's path for the CLI (`--camera PATH:NAME`, `--camera-database PATH`), or `None`
/// after the skip message of [`database`].
pub fn database_path(what: &str) -> Option<PathBuf> {
    database(what).map(|_| path())
}

/// The database's bytes, or `None` after a skip message naming `what` did not run.
pub fn database(what: &str) -> Option<Vec<u8>> {
    let p = path();
    match std::fs::read(&p) {
        Ok(b) => Some(b),
        Err(_) => {
            assert!(
                std::env::var("LUMIFIT_REQUIRE_DATA").as_deref() != Ok("1"),
                "LUMIFIT_REQUIRE_DATA=1 but {} is missing",
                p.display()
            );
            eprintln!("SKIPPED: {} is absent; {what} did not run", p.display());
            None
        }
    }
}

/// One camera of the database.
pub fn camera(db: &[u8], name: &str) -> MultiSpectrum {
    parse_camera_database(db, DATABASE, name).unwrap()
}

/// The Academy-JSON camera file `rel` under ../shared/data/camera (e.g.
/// `rawtoaces-data/Canon_EOS_5D_Mark_II_380_780_5.json`), or `None` after a skip message.
pub fn academy(rel: &str) -> Option<MultiSpectrum> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/camera")
        .join(rel);
    match std::fs::read(&p) {
        Ok(b) => Some(lumifit::io::camera::parse_camera_file(&b, rel).unwrap()),
        Err(_) => {
            assert!(
                std::env::var("LUMIFIT_REQUIRE_DATA").as_deref() != Ok("1"),
                "LUMIFIT_REQUIRE_DATA=1 but {} is missing",
                p.display()
            );
            eprintln!(
                "SKIPPED: {} is absent; the camera-file checks did not run",
                p.display()
            );
            None
        }
    }
}
