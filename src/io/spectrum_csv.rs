//! Spectra as CSV: `wavelength_nm,value[,…]` with a header row.

use std::path::Path;

use crate::error::{Error, Result};
use crate::spectrum::{MultiSpectrum, Spectrum};
use crate::table::parse_numeric_csv;

/// Whether a column only accompanies the value (its uncertainty or sample count), so a
/// single-spectrum reader can ignore it: `std`, `*_std`, `sigma`, `n_pixels`.
pub fn is_auxiliary_column(name: &str) -> bool {
    let n = name.trim().to_ascii_lowercase();
    n == "std" || n.ends_with("_std") || n == "sigma" || n == "n_pixels"
}

/// Reads a single spectrum (`wavelength_nm,value`) from a file or `-`. Auxiliary columns
/// ([`is_auxiliary_column`]: what `spectrum recover` writes beside the value) are ignored, so one
/// command's output is the next one's input; any other extra column is an error, since it would
/// be ambiguous which column is the spectrum.
pub fn read_spectrum(path: &Path) -> Result<Spectrum> {
    let (bytes, source) = super::read_input(path)?;
    let table = parse_numeric_csv(&bytes, &source)?;
    let values: Vec<usize> = (1..table.header.len())
        .filter(|&c| !is_auxiliary_column(&table.header[c]))
        .collect();
    if values.len() != 1 {
        return Err(Error::parse(
            source,
            1,
            format!(
                "expected 2 columns 'wavelength_nm,value' (plus optional std/*_std/n_pixels), found {} ({}); for several spectra use a command that reads a table (e.g. color table --sds)",
                table.header.len(),
                table.header.join(",")
            ),
        ));
    }
    Spectrum::from_table(&table, values[0])
}

/// Reads a multi-column spectral table (`wavelength_nm,a,b,…`) from a file or `-`.
pub fn read_multi_spectrum(path: &Path) -> Result<MultiSpectrum> {
    let (bytes, source) = super::read_input(path)?;
    let table = parse_numeric_csv(&bytes, &source)?;
    MultiSpectrum::from_table(&table)
}

/// Formats a spectrum as CSV text with the given value column name.
pub fn spectrum_to_csv(sd: &Spectrum, value_column: &str) -> String {
    let mut s = format!("wavelength_nm,{value_column}\n");
    for (w, v) in sd.wavelengths().iter().zip(sd.values()) {
        s.push_str(&format!("{w},{v}\n"));
    }
    s
}

/// Writes a spectrum as CSV atomically.
pub fn write_spectrum(path: &Path, sd: &Spectrum, value_column: &str) -> Result<()> {
    super::atomic_write(path, spectrum_to_csv(sd, value_column).as_bytes())
}

/// Formats a multi-spectral distribution as CSV text.
pub fn multi_spectrum_to_csv(ms: &MultiSpectrum) -> String {
    let mut s = String::from("wavelength_nm");
    for l in ms.labels() {
        s.push(',');
        s.push_str(l);
    }
    s.push('\n');
    for (i, w) in ms.wavelengths().iter().enumerate() {
        s.push_str(&w.to_string());
        for c in ms.channels() {
            s.push(',');
            s.push_str(&c[i].to_string());
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_recovered_spectrum_with_its_std_column_reads_as_one_spectrum() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("rec.csv");
        std::fs::write(&p, "wavelength_nm,value,std\n400,0.5,0.01\n410,0.6,0.02\n").unwrap();
        let sd = read_spectrum(&p).unwrap();
        assert_eq!(sd.values(), &[0.5, 0.6]);
        std::fs::write(&p, "wavelength_nm,a,b\n400,0.5,0.1\n410,0.6,0.2\n").unwrap();
        let e = read_spectrum(&p).unwrap_err().to_string();
        assert!(e.contains("line 1") && e.contains("a,b"), "{e}");
    }

    #[test]
    fn a_written_spectrum_reads_back_identically() {
        let sd =
            Spectrum::new("s", vec![400.0, 405.5, 410.0], vec![0.1, 1.0 / 3.0, 2e-17]).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.csv");
        write_spectrum(&p, &sd, "value").unwrap();
        let back = read_spectrum(&p).unwrap();
        assert_eq!(back.values(), sd.values());
        assert_eq!(back.wavelengths(), sd.wavelengths());
    }
}
