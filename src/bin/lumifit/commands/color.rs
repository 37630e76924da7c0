//! `lumifit color …`: spectra to tristimulus values, colour differences, conversions.

use anyhow::Result;
use lumifit::io::Outputs;
use lumifit::pipeline::color::{self as job, ConvertJob, TableJob, XyzSettings};

use super::emit;
use crate::args::{ConvertArgs, DeltaEArgs, TableArgs, XyzArgs};

/// `lumifit color xyz`.
pub fn xyz(a: &XyzArgs) -> Result<()> {
    let settings = XyzSettings {
        illuminant: a.illuminant.clone(),
        observer: a.observer.clone(),
        method: a.method.clone(),
    };
    let report = job::xyz(&a.sd, &settings, a.k)?;
    emit(&serde_json::to_string_pretty(&report)?)
}

/// `lumifit color table`: XYZ, xy and Lab of every column of a spectral table.
pub fn table(a: &TableArgs) -> Result<()> {
    let table = TableJob {
        spectra: a.sds.clone(),
        settings: XyzSettings {
            illuminant: a.illuminant.clone(),
            observer: a.observer.clone(),
            method: a.method.clone(),
        },
        out: a.out.clone(),
    };
    let mut out = Outputs::new();
    let summary = job::run_table(&table, &mut out)?;
    out.commit()?;
    emit(&summary.to_string())
}

/// `lumifit color delta-e`.
pub fn delta_e(a: &DeltaEArgs) -> Result<()> {
    emit(&job::delta_e_of(&a.lab1, &a.lab2, &a.method)?.to_string())
}

/// `lumifit color convert`.
pub fn convert(a: &ConvertArgs) -> Result<()> {
    let conversion = ConvertJob {
        from: a.from.clone(),
        to: a.to.clone(),
        value: a.value.clone(),
        scale: a.scale.clone(),
        white: a.white.clone(),
    };
    emit(&job::convert(&conversion, &mut |w| eprintln!("{w}"))?.to_string())
}
