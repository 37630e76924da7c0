//! EULUMDAT (.ldt) photometric files: reader and writer.
//!
//! Line layout (one field per line): 1 company, 2 type indicator Ityp, 3 symmetry Isym (0–4),
//! 4 Mc (C planes in the full circle), 5 Dc, 6 Ng (γ angles per plane), 7 Dg, 8 report number,
//! 9 luminaire name, 10 luminaire number, 11 file name, 12 date/user, 13–15 luminaire length
//! (along C0–C180), width (C90–C270), height in mm, 16–17 luminous area length and width in mm
//! (width 0: circular), 18–21 luminous area heights at C0/C90/C180/C270, 22 DFF %, 23 LORL %,
//! 24 conversion factor, 25 measurement tilt, 26 number of lamp sets n, then n × (26a number of
//! lamps — negative for absolute photometry —, 26b type, 26c total flux lm, 26d colour
//! temperature, 26e colour rendering, 26f wattage), 27 ten direct ratios, 28 Mc C angles, 29 Ng
//! γ angles, 30 intensities in cd/klm for the stored planes.
//!
//! Stored planes per Isym: 0 all Mc; 1 one; 2 C0–C180 (Mc/2 + 1); 3 C90–C270 (Mc/2 + 1, from
//! C90); 4 C0–C90 (Mc/4 + 1). Candela = value × conversion factor × Φ₁ / 1000 with Φ₁ the first
//! lamp set's flux (the measured configuration); a negative lamp count marks absolute
//! photometry, where Φ₁ is the luminaire's flux and no lamp flux is declared. Decimal commas are
//! accepted.
//!
//! The writer keeps the symmetry, writes conversion factor 1 and values in cd/klm of the first
//! lamp set's flux (or of 1000 lm for absolute photometry with no declared flux), each in the
//! shortest form that reads back to the same f64; the candela grid read back differs from the
//! one written by at most a few ulp (the division and multiplication by Φ/1000 round).

use std::path::Path;

use crate::error::{Error, Result};
use crate::photometry::{
    CandelaGrid, FileFormat, LampSet, LuminousOpening, OpeningShape, PhotometricFile,
    PhotometricType, Photometry, Symmetry, Tilt,
};

struct Lines<'a> {
    lines: Vec<&'a str>,
    pos: usize,
    source: &'a str,
}

impl<'a> Lines<'a> {
    fn text(&mut self, field: &str) -> Result<&'a str> {
        let Some(l) = self.lines.get(self.pos) else {
            return Err(Error::parse(
                self.source,
                self.pos + 1,
                format!("file ends before {field} (truncated?)"),
            ));
        };
        self.pos += 1;
        Ok(l.trim())
    }

    fn f64(&mut self, field: &str) -> Result<f64> {
        let t = self.text(field)?;
        let v: f64 = t.replace(',', ".").parse().map_err(|_| {
            Error::parse(
                self.source,
                self.pos,
                format!("{field}: '{t}' is not a number"),
            )
        })?;
        if !v.is_finite() {
            return Err(Error::parse(
                self.source,
                self.pos,
                format!("{field}: '{t}' is not finite"),
            ));
        }
        Ok(v)
    }

    fn int(&mut self, field: &str, lo: i64, hi: i64) -> Result<i64> {
        let v = self.f64(field)?;
        if v.fract() != 0.0 || v < lo as f64 || v > hi as f64 {
            return Err(Error::parse(
                self.source,
                self.pos,
                format!("{field}: {v}; expected an integer from {lo} to {hi}"),
            ));
        }
        Ok(v as i64)
    }
}

const FIELDS: [&str; 5] = [
    "report number",
    "luminaire name",
    "luminaire number",
    "file name",
    "date/user",
];

/// Parses EULUMDAT text; `source` names the file in errors.
pub fn parse_ldt(bytes: &[u8], source: &str) -> Result<PhotometricFile> {
    let text = crate::table::as_text(bytes, source, "an EULUMDAT (.ldt) photometric file")?;
    let mut ln = Lines {
        lines: text.lines().collect(),
        pos: 0,
        source,
    };
    let mut notes = Vec::new();
    let company = ln.text("company identification (line 1)")?.to_string();
    let ityp = ln.int("type indicator Ityp (line 2)", 0, 3)? as u8;
    let isym = ln.int("symmetry indicator Isym (line 3)", 0, 4)?;
    let mc = ln.int(
        "number of C planes Mc (line 4)",
        1,
        super::ies::MAX_ANGLES as i64,
    )? as usize;
    let dc = ln.f64("distance between C planes Dc (line 5)")?;
    let ng = ln.int(
        "number of intensities per plane Ng (line 6)",
        1,
        super::ies::MAX_ANGLES as i64,
    )? as usize;
    let dg = ln.f64("distance between intensities Dg (line 7)")?;
    crate::limits::check_memory(
        "number of intensities",
        &format!("{mc}x{ng}"),
        (mc * ng) as u128,
        16,
    )?;
    let mut keywords = vec![("COMPANY".to_string(), company)];
    for (i, f) in FIELDS.iter().enumerate() {
        let v = ln.text(&format!("{f} (line {})", 8 + i))?.to_string();
        keywords.push((f.to_ascii_uppercase().replace(['/', ' '], "_"), v));
    }
    let mut dims = [0.0; 9];
    let dim_names = [
        "luminaire length (line 13)",
        "luminaire width (line 14)",
        "luminaire height (line 15)",
        "luminous area length (line 16)",
        "luminous area width (line 17)",
        "luminous area height C0 (line 18)",
        "luminous area height C90 (line 19)",
        "luminous area height C180 (line 20)",
        "luminous area height C270 (line 21)",
    ];
    for (d, name) in dims.iter_mut().zip(dim_names) {
        *d = ln.f64(name)?;
        if *d < 0.0 {
            return Err(Error::parse(
                source,
                ln.pos,
                format!("{name}: {d} mm is negative"),
            ));
        }
    }
    let dff = ln.f64("downward flux fraction DFF (line 22)")?;
    let lorl = ln.f64("light output ratio LORL (line 23)")?;
    let conv = ln.f64("conversion factor (line 24)")?;
    if conv <= 0.0 {
        return Err(Error::parse(
            source,
            ln.pos,
            format!("conversion factor: {conv}; expected > 0"),
        ));
    }
    let tilt_deg = ln.f64("tilt during measurement (line 25)")?;
    let n_sets = ln.int("number of lamp sets n (line 26)", 1, 1000)? as usize;
    let mut lamps = Vec::with_capacity(n_sets);
    for s in 1..=n_sets {
        let count = ln.int(
            &format!("lamp set {s}: number of lamps (26a)"),
            -1_000_000,
            1_000_000,
        )?;
        if count == 0 {
            return Err(Error::parse(source, ln.pos, format!("lamp set {s}: number of lamps is 0; expected a positive count, or negative for absolute photometry")));
        }
        let kind = ln.text(&format!("lamp set {s}: type (26b)"))?.to_string();
        let flux = ln.f64(&format!("lamp set {s}: total luminous flux (26c)"))?;
        if flux <= 0.0 {
            return Err(Error::parse(
                source,
                ln.pos,
                format!("lamp set {s}: luminous flux {flux} lm; expected > 0"),
            ));
        }
        let cct = ln
            .text(&format!("lamp set {s}: colour temperature (26d)"))?
            .to_string();
        let cri = ln
            .text(&format!("lamp set {s}: colour rendering (26e)"))?
            .to_string();
        let watts = ln.f64(&format!("lamp set {s}: wattage (26f)"))?;
        lamps.push(LampSet {
            count,
            kind,
            flux_lm: flux,
            colour_temperature: cct,
            colour_rendering: cri,
            watts,
        });
    }
    if n_sets > 1 {
        notes.push(format!(
            "{n_sets} lamp sets; intensities scaled by set 1 (the measured configuration)"
        ));
    }
    let mut dr = Vec::with_capacity(10);
    for k in 0..10 {
        dr.push(ln.f64(&format!("direct ratio {} (line 27)", k + 1))?);
    }
    let c_line = ln.pos + 1;
    let mut c = Vec::with_capacity(mc);
    for k in 0..mc {
        c.push(ln.f64(&format!("C angle {} of {mc} (line 28)", k + 1))?);
    }
    let g_line = ln.pos + 1;
    let mut g = Vec::with_capacity(ng);
    for k in 0..ng {
        g.push(ln.f64(&format!("γ angle {} of {ng} (line 29)", k + 1))?);
    }
    for (a, line, name, hi) in [
        (&c, c_line, "C angles", 360.0),
        (&g, g_line, "γ angles", 180.0),
    ] {
        if let Some(i) = a.windows(2).position(|w| w[1] <= w[0]) {
            return Err(Error::parse(
                source,
                line + i + 1,
                format!(
                    "{name}: not strictly increasing ({} then {})",
                    a[i],
                    a[i + 1]
                ),
            ));
        }
        if a[0] < 0.0 || a[a.len() - 1] > hi || (name == "C angles" && a[a.len() - 1] >= 360.0) {
            return Err(Error::parse(
                source,
                line,
                format!(
                    "{name} {}–{}: expected angles within 0–{hi}°",
                    a[0],
                    a[a.len() - 1]
                ),
            ));
        }
    }
    if mc > 1 && dc > 0.0 && ((c[1] - c[0]) - dc).abs() > 1e-6 {
        notes.push(format!(
            "Dc = {dc}° but the C angles step by {}°; the listed angles are used",
            c[1] - c[0]
        ));
    }
    if ng > 1 && dg > 0.0 && ((g[1] - g[0]) - dg).abs() > 1e-6 {
        notes.push(format!(
            "Dg = {dg}° but the γ angles step by {}°; the listed angles are used",
            g[1] - g[0]
        ));
    }
    let (symmetry, first, count) = match isym {
        0 => (Symmetry::None, 0, mc),
        1 => (Symmetry::Rotational, 0, 1),
        2 => (Symmetry::C0C180, 0, mc / 2 + 1),
        3 => (Symmetry::C90C270, mc / 4, mc / 2 + 1),
        _ => (Symmetry::Quadrant, 0, mc / 4 + 1),
    };
    let divisor = match isym {
        2 => 2,
        3 | 4 => 4,
        _ => 1,
    };
    if mc % divisor != 0 || first + count > mc {
        return Err(Error::parse(source, 4, format!("Mc = {mc} C planes cannot hold symmetry Isym {isym}; expected Mc divisible by {divisor}")));
    }
    let data_line = ln.pos + 1;
    let mut raw = Vec::with_capacity(count * ng);
    for (p, c_p) in c[first..first + count].iter().enumerate() {
        for (k, g_k) in g.iter().enumerate() {
            let v = ln.f64(&format!(
                "intensity (plane {} of {count}, γ {} of {ng})",
                p + 1,
                k + 1
            ))?;
            if v < 0.0 {
                return Err(Error::parse(
                    source,
                    ln.pos,
                    format!(
                        "intensity {v} cd/klm at C {}°, γ {}° is negative; expected ≥ 0",
                        c_p, g_k
                    ),
                ));
            }
            raw.push(v);
        }
    }
    if let Some(extra) = ln.lines[ln.pos..].iter().position(|l| !l.trim().is_empty()) {
        return Err(Error::parse(source, ln.pos + extra + 1, format!("value after the {} intensities that Isym {isym} with Mc = {mc}, Ng = {ng} stores (from line {data_line}); is a count wrong?", count * ng)));
    }
    let phi1 = lamps[0].flux_lm;
    let absolute = lamps[0].count < 0;
    let k = conv * phi1 / 1000.0;
    let cd: Vec<f64> = raw.iter().map(|v| v * k).collect();
    let hs: Vec<f64> = if symmetry == Symmetry::Rotational {
        vec![0.0]
    } else {
        c[first..first + count].to_vec()
    };
    if symmetry == Symmetry::C90C270 && (c[first] != 90.0 || c[first + count - 1] != 270.0) {
        return Err(Error::parse(
            source,
            c_line,
            format!(
                "Isym 3 stores C90–C270 but the C angles there are {}–{}",
                c[first],
                c[first + count - 1]
            ),
        ));
    }
    let grid = CandelaGrid::expand_type_c(symmetry, &hs, g, &cd)
        .map_err(|e| Error::parse(source, data_line, e.to_string()))?;
    let circular = dims[4] == 0.0;
    let opening = LuminousOpening {
        length_m: dims[3] / 1000.0,
        width_m: if circular { dims[3] } else { dims[4] } / 1000.0,
        height_m: dims[5..9].iter().cloned().fold(0.0, f64::max) / 1000.0,
        shape: if dims[3] == 0.0 && dims[4] == 0.0 {
            OpeningShape::Point
        } else if circular {
            OpeningShape::Circular
        } else {
            OpeningShape::Rectangular
        },
    };
    keywords.push((
        "LUMINAIRE_DIMENSIONS_MM".into(),
        format!("{} {} {}", dims[0], dims[1], dims[2]),
    ));
    keywords.push(("MEASUREMENT_TILT_DEG".into(), format!("{tilt_deg}")));
    Ok(PhotometricFile {
        format: FileFormat::Eulumdat,
        version: "EULUMDAT".into(),
        keywords,
        input_watts: lamps[0].watts,
        lamps,
        direct_ratios: dr,
        ldt_type_indicator: ityp,
        notes,
        photometry: Photometry {
            grid,
            symmetry,
            lamp_flux_lm: (!absolute).then_some(phi1),
            declared_luminaire_flux_lm: absolute.then_some(phi1),
            declared_lor_percent: Some(lorl),
            declared_dff_percent: Some(dff),
            opening,
            tilt: Tilt::None,
            tilt_applied: (0.0, 1.0),
        },
    })
}

/// Reads an EULUMDAT file.
pub fn read_ldt(path: &Path) -> Result<PhotometricFile> {
    let (bytes, source) = super::read_input(path)?;
    parse_ldt(&bytes, &source)
}

fn uniform_step(a: &[f64]) -> f64 {
    if a.len() < 2 {
        return 0.0;
    }
    let d = a[1] - a[0];
    if a.windows(2).all(|w| ((w[1] - w[0]) - d).abs() < 1e-9) {
        d
    } else {
        0.0
    }
}

/// Writes EULUMDAT text (module docs). Types A/B cannot be written (EULUMDAT is C-γ only).
pub fn write_ldt(file: &PhotometricFile, tool: &str) -> Result<String> {
    let p = &file.photometry;
    let g = &p.grid;
    if g.kind != PhotometricType::C {
        return Err(Error::invalid("EULUMDAT writer", format!("Type {:?} photometry cannot be written as EULUMDAT, which holds Type C only; write IES instead", g.kind)));
    }
    let isym = match p.symmetry {
        Symmetry::None => 0,
        Symmetry::Rotational => 1,
        Symmetry::C0C180 => 2,
        Symmetry::C90C270 => 3,
        _ => 4,
    };
    let mc = g.h_deg.len();
    let divisor = [1, 1, 2, 4, 4][isym];
    if mc % divisor != 0 {
        return Err(Error::invalid(
            "EULUMDAT writer",
            format!("{mc} C planes cannot carry symmetry Isym {isym}"),
        ));
    }
    let kw = |k: &str, fallback: &str| {
        file.keyword(k)
            .map(|s| s.replace('\n', " "))
            .unwrap_or_else(|| fallback.to_string())
    };
    let mut o = String::new();
    let mut line = |s: String| {
        o.push_str(&s);
        o.push('\n');
    };
    line(kw("COMPANY", &kw("MANUFAC", "unknown")));
    line(format!(
        "{}",
        if file.format == FileFormat::Eulumdat {
            file.ldt_type_indicator
        } else if isym == 1 {
            1
        } else {
            3
        }
    ));
    line(format!("{isym}"));
    line(format!("{mc}"));
    line(format!("{}", uniform_step(&g.h_deg)));
    line(format!("{}", g.v_deg.len()));
    line(format!("{}", uniform_step(&g.v_deg)));
    line(kw("REPORT_NUMBER", &kw("TEST", "")));
    line(kw("LUMINAIRE_NAME", &kw("LUMINAIRE", "")));
    line(kw("LUMINAIRE_NUMBER", &kw("LUMCAT", "")));
    line(kw("FILE_NAME", ""));
    line(
        format!("{} {}", kw("DATE_USER", &kw("ISSUEDATE", "")), tool)
            .trim()
            .to_string(),
    );
    let op = &p.opening;
    let mm = |m: f64| format!("{}", m * 1000.0);
    let lum = file
        .keyword("LUMINAIRE_DIMENSIONS_MM")
        .map(|s| s.split_whitespace().map(str::to_string).collect::<Vec<_>>())
        .filter(|v| v.len() == 3);
    match lum {
        Some(v) => v.into_iter().for_each(&mut line),
        None => {
            line(mm(op.length_m));
            line(mm(if op.shape == OpeningShape::Circular {
                0.0
            } else {
                op.width_m
            }));
            line(mm(op.height_m));
        }
    }
    line(mm(op.length_m));
    line(mm(if op.shape == OpeningShape::Circular {
        0.0
    } else {
        op.width_m
    }));
    for _ in 0..4 {
        line(mm(op.height_m));
    }
    let s = crate::photometry::summary(p);
    line(format!(
        "{}",
        p.declared_dff_percent.unwrap_or(if s.flux_lm > 0.0 {
            100.0 * s.flux_down_lm / s.flux_lm
        } else {
            100.0
        })
    ));
    line(format!(
        "{}",
        p.declared_lor_percent
            .unwrap_or(s.lor.map(|l| 100.0 * l).unwrap_or(100.0))
    ));
    line("1".into());
    line("0".into());
    let absolute = p.lamp_flux_lm.is_none();
    let phi1 = p
        .lamp_flux_lm
        .or(p.declared_luminaire_flux_lm)
        .unwrap_or(1000.0);
    let sets: Vec<LampSet> = if file.lamps.is_empty() || file.format == FileFormat::Ies {
        vec![LampSet {
            count: if absolute {
                -1
            } else {
                file.lamps.first().map(|l| l.count).unwrap_or(1).max(1)
            },
            kind: kw("LAMP", "unknown"),
            flux_lm: phi1,
            colour_temperature: String::new(),
            colour_rendering: String::new(),
            watts: file.input_watts,
        }]
    } else {
        let mut v = file.lamps.clone();
        v[0].flux_lm = phi1;
        v
    };
    line(format!("{}", sets.len()));
    for l in &sets {
        line(format!("{}", l.count));
        line(l.kind.replace('\n', " "));
        line(format!("{}", l.flux_lm));
        line(l.colour_temperature.clone());
        line(l.colour_rendering.clone());
        line(format!("{}", l.watts));
    }
    let dr: Vec<f64> = if file.direct_ratios.len() == 10 {
        file.direct_ratios.clone()
    } else {
        vec![0.0; 10]
    };
    for d in dr {
        line(format!("{d}"));
    }
    for c in &g.h_deg {
        line(format!("{c}"));
    }
    for v in &g.v_deg {
        line(format!("{v}"));
    }
    let planes: Vec<usize> = match isym {
        1 => vec![0],
        _ => super::ies::stored_planes(g, p.symmetry),
    };
    let nv = g.nv();
    let k = 1000.0 / phi1;
    for i in planes {
        for v in &g.cd[i * nv..(i + 1) * nv] {
            line(format!("{}", v * k));
        }
    }
    Ok(o)
}
