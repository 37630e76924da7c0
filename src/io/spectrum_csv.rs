//! Spectra as CSV: `wavelength_nm,value[,…]` with a header row.

use std::path::Path;

use crate::error::{Error, Result};
use crate::spectrum::{MultiSpectrum, Spectrum};
use crate::table::parse_numeric_csv;

/// Reads a single spectrum (`wavelength_nm,value`; extra columns are an error) from a file or `-`.
pub fn read_spectrum(path: &Path) -> Result<Spectrum> {
    let (bytes, source) = super::read_input(path)?;
    let table = parse_numeric_csv(&bytes, &source)?;
    if table.header.len() != 2 {
        return Err(Error::parse(
            source,
            1,
            format!(
                "expected 2 columns 'wavelength_nm,value', found {} ({})",
                table.header.len(),
                table.header.join(",")
            ),
        ));
    }
    Spectrum::from_table(&table, 1)
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
