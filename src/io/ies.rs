//! IES LM-63 photometric files (1986, 1991, 1995, 2002, 2019): reader and LM-63-2019 writer.
//!
//! Reading follows the standard's layout: a version line (absent in LM-63-1986; tolerated with
//! spaces, `IESNA: LM-63-2002`), label/keyword lines up to `TILT=` (`[MORE]` continues the
//! previous keyword), the TILT section (`NONE`, `INCLUDE` with its table inline, or a file name
//! resolved beside the IES file), then whitespace- or comma-separated numbers:
//!
//! lamps, lumens/lamp (−1 = absolute), candela multiplier, #vertical, #horizontal, photometric
//! type (1 = C, 2 = B, 3 = A), units (1 = feet, 2 = metres), width, length, height;
//! ballast factor, third field, input watts; vertical angles; horizontal angles; candela.
//!
//! The third field is the ballast-lamp photometric factor in 1986–1995 (multiplied), "future use"
//! in 2002 and the file-generation type in 2019 (**not** multiplied; Blender's importer multiplies
//! by it). Candela = value × multiplier × ballast factor [× ballast-lamp factor] × TILT factor at
//! the lamp tilt asked for (0° = as photometered). Horizontal layouts for Type C: one angle
//! (rotational), 0–90, 0–180, 90–270, 0–360 (the 360° plane must repeat 0° and is dropped);
//! Types A/B: 0–90 (mirrored) or −90–90. Width is along C90–C270, length along C0–C180.
//!
//! Text goes through [`crate::table::as_text`] (BOM, CRLF and binary handled as everywhere).
//! Every error names the file, the line and the field.
//!
//! The writer writes LM-63-2019 with multiplier 1, ballast factor 1, file-generation type 1.00001
//! ("undefined"), metres, TILT=NONE (a TILT factor already applied) and every intensity in the
//! shortest form that reads back to the same f64, so read → write → read gives the same grid.

use std::path::Path;

use crate::error::{Error, Result};
use crate::photometry::{
    CandelaGrid, FileFormat, LampSet, LuminousOpening, OpeningShape, PhotometricFile,
    PhotometricType, Photometry, Symmetry, Tilt,
};

/// Loads a `TILT=<file>` by name: its bytes and a display name for errors.
pub type TiltLoader<'a> = dyn Fn(&str) -> Result<(Vec<u8>, String)> + 'a;

/// Most angles accepted on one axis (LM-63 files have at most a few hundred).
pub const MAX_ANGLES: usize = 100_000;

struct Tokens<'a> {
    toks: Vec<(&'a str, usize)>,
    pos: usize,
    source: String,
    end_line: usize,
}

impl<'a> Tokens<'a> {
    fn new(lines: &[&'a str], first_line: usize, source: &str) -> Self {
        let mut toks = Vec::new();
        for (i, l) in lines.iter().enumerate() {
            for t in l
                .split(|c: char| c.is_whitespace() || c == ',')
                .filter(|t| !t.is_empty())
            {
                toks.push((t, first_line + i));
            }
        }
        Tokens {
            toks,
            pos: 0,
            source: source.to_string(),
            // the last line of the file (the line before `first_line` when nothing follows)
            end_line: (first_line + lines.len()).saturating_sub(1).max(1),
        }
    }

    fn last_line(&self) -> usize {
        self.toks.last().map(|t| t.1).unwrap_or(self.end_line)
    }

    fn f64(&mut self, field: &str) -> Result<f64> {
        let Some(&(t, line)) = self.toks.get(self.pos) else {
            return Err(Error::parse(
                &self.source,
                self.last_line(),
                format!("file ends before {field} (truncated, or a count above is too large)"),
            ));
        };
        self.pos += 1;
        let v: f64 = t.parse().map_err(|_| {
            Error::parse(
                &self.source,
                line,
                format!("{field}: '{t}' is not a number"),
            )
        })?;
        if !v.is_finite() {
            return Err(Error::parse(
                &self.source,
                line,
                format!("{field}: '{t}' is not finite"),
            ));
        }
        Ok(v)
    }

    fn line(&self) -> usize {
        self.toks
            .get(self.pos.saturating_sub(1))
            .map(|t| t.1)
            .unwrap_or(0)
    }

    fn int(&mut self, field: &str, lo: i64, hi: i64) -> Result<i64> {
        let v = self.f64(field)?;
        if v.fract() != 0.0 || v < lo as f64 || v > hi as f64 {
            return Err(Error::parse(
                &self.source,
                self.line(),
                format!("{field}: {v}; expected an integer from {lo} to {hi}"),
            ));
        }
        Ok(v as i64)
    }

    fn many(&mut self, n: usize, field: &str) -> Result<(Vec<f64>, usize)> {
        let line = self
            .toks
            .get(self.pos)
            .map(|t| t.1)
            .unwrap_or(self.last_line());
        let mut v = Vec::with_capacity(n);
        for i in 0..n {
            v.push(self.f64(&format!("{field} #{}", i + 1))?);
        }
        Ok((v, line))
    }

    fn increasing(&self, v: &[f64], line: usize, field: &str) -> Result<()> {
        if let Some(i) = v.windows(2).position(|w| w[1] <= w[0]) {
            return Err(Error::parse(
                &self.source,
                line,
                format!(
                    "{field}: not strictly increasing at #{} ({} then {})",
                    i + 2,
                    v[i],
                    v[i + 1]
                ),
            ));
        }
        Ok(())
    }
}

/// LM-63 version from the first line: (`year`, whether that line was a version line).
fn version_of(first: &str) -> (Option<u32>, bool) {
    let compact: String = first
        .chars()
        .filter(|c| !c.is_whitespace())
        .collect::<String>()
        .to_ascii_uppercase();
    if compact.starts_with("IESNA91") {
        return (Some(1991), true);
    }
    if compact.starts_with("IESNA") || compact.starts_with("IES:") {
        let year = compact
            .find("LM-63-")
            .and_then(|i| compact[i + 6..].get(..4))
            .and_then(|y| y.parse::<u32>().ok());
        let year = year.map(|y| if y < 100 { 1900 + y } else { y });
        return (year, true);
    }
    (Some(1986), false)
}

fn parse_tilt(tok: &mut Tokens, source_name: String) -> Result<Tilt> {
    let geometry = tok.int("TILT lamp-to-luminaire geometry", 1, 3)? as u8;
    let n = tok.int("TILT number of angle/factor pairs", 1, MAX_ANGLES as i64)? as usize;
    let (angles, l) = tok.many(n, "TILT angle")?;
    tok.increasing(&angles, l, "TILT angles")?;
    let (factors, l2) = tok.many(n, "TILT multiplying factor")?;
    if let Some(i) = factors.iter().position(|f| *f < 0.0) {
        return Err(Error::parse(
            &tok.source,
            l2,
            format!(
                "TILT multiplying factor #{}: {} is negative",
                i + 1,
                factors[i]
            ),
        ));
    }
    // The table ends at a line end: a count that does not match the values shows here.
    let last = tok.line();
    if let Some(&(t, l)) = tok.toks.get(tok.pos) {
        if l == last {
            return Err(Error::parse(&tok.source, l, format!("TILT table of {n} angle/factor pairs ends mid-line before '{t}'; is the TILT count wrong?")));
        }
    }
    Ok(Tilt::Table {
        source: source_name,
        geometry,
        angles_deg: angles,
        factors,
    })
}

/// Parses IES LM-63 text. `source` names the file in errors; `tilt_file` loads a `TILT=<file>`
/// (bytes and display name); `lamp_tilt_deg` is the lamp tilt at which a TILT table is applied.
pub fn parse_ies(
    bytes: &[u8],
    source: &str,
    tilt_file: &TiltLoader,
    lamp_tilt_deg: f64,
) -> Result<PhotometricFile> {
    let text = crate::table::as_text(bytes, source, "an IES LM-63 photometric file")?;
    let lines: Vec<&str> = text.lines().collect();
    if lines.iter().all(|l| l.trim().is_empty()) {
        return Err(Error::parse(
            source,
            1,
            "empty file; expected an IES LM-63 photometric file",
        ));
    }
    let (year, has_version_line) = version_of(lines[0]);
    let mut notes = Vec::new();
    let version = match (year, has_version_line) {
        (Some(y), _) => format!("LM-63-{y}"),
        (None, _) => {
            notes.push(format!(
                "version line '{}' names no LM-63 year; read as LM-63-2002",
                lines[0].trim()
            ));
            "LM-63-2002".to_string()
        }
    };
    let year = year.unwrap_or(2002);
    let start = usize::from(has_version_line);
    let tilt_idx = lines
        .iter()
        .enumerate()
        .skip(start)
        .find(|(_, l)| l.trim_start().to_ascii_uppercase().starts_with("TILT"))
        .map(|(i, _)| i);
    let Some(tilt_idx) = tilt_idx else {
        return Err(Error::parse(source, lines.len(), "no TILT= line; expected TILT=NONE, TILT=INCLUDE or TILT=<file> after the keyword lines"));
    };
    let mut keywords: Vec<(String, String)> = Vec::new();
    for (i, l) in lines[start..tilt_idx].iter().enumerate() {
        let t = l.trim();
        if t.is_empty() {
            continue;
        }
        if let Some(rest) = t.strip_prefix('[') {
            if let Some(end) = rest.find(']') {
                let key = rest[..end].trim().to_ascii_uppercase();
                let val = rest[end + 1..].trim().to_string();
                if key == "MORE" {
                    match keywords.last_mut() {
                        Some(last) => {
                            last.1.push('\n');
                            last.1.push_str(&val);
                        }
                        None => notes.push(format!(
                            "line {}: [MORE] before any keyword; kept as its own keyword",
                            start + i + 1
                        )),
                    }
                    if keywords.is_empty() {
                        keywords.push((key, val));
                    }
                } else {
                    keywords.push((key, val));
                }
                continue;
            }
        }
        // LM-63-1986 labels (and stray lines in later versions) are kept as free text.
        if year > 1986 {
            notes.push(format!(
                "line {}: '{t}' is not a [KEYWORD] line; kept as a label",
                start + i + 1
            ));
        }
        keywords.push(("LABEL".into(), t.to_string()));
    }
    let tilt_line = lines[tilt_idx].trim();
    let tilt_value = match tilt_line.split_once('=') {
        Some((_, v)) => v.trim(),
        None => {
            return Err(Error::parse(
                source,
                tilt_idx + 1,
                format!("'{tilt_line}': expected TILT=NONE, TILT=INCLUDE or TILT=<file>"),
            ))
        }
    };
    let mut tok = Tokens::new(&lines[tilt_idx + 1..], tilt_idx + 2, source);
    let tilt = if tilt_value.eq_ignore_ascii_case("NONE") {
        Tilt::None
    } else if tilt_value.eq_ignore_ascii_case("INCLUDE") {
        parse_tilt(&mut tok, "INCLUDE".into())?
    } else if tilt_value.is_empty() {
        return Err(Error::parse(
            source,
            tilt_idx + 1,
            "'TILT=' names no file; expected TILT=NONE, TILT=INCLUDE or TILT=<file>",
        ));
    } else {
        let (tb, tname) = tilt_file(tilt_value)?;
        let ttext = crate::table::as_text(&tb, &tname, "an LM-63 TILT file")?;
        let tlines: Vec<&str> = ttext.lines().collect();
        let mut tt = Tokens::new(&tlines, 1, &tname);
        let t = parse_tilt(&mut tt, tilt_value.to_string())?;
        if tt.pos < tt.toks.len() {
            return Err(Error::parse(
                &tname,
                tt.toks[tt.pos].1,
                "values after the TILT table; expected the table only",
            ));
        }
        t
    };
    let n_lamps = tok.int("number of lamps", 1, 1_000_000)?;
    let lumens = tok.f64("lumens per lamp")?;
    if !(lumens > 0.0 || lumens == -1.0) {
        return Err(Error::parse(source, tok.line(), format!("lumens per lamp: {lumens}; expected a positive number, or -1 for absolute photometry")));
    }
    let multiplier = tok.f64("candela multiplier")?;
    if multiplier <= 0.0 {
        return Err(Error::parse(
            source,
            tok.line(),
            format!("candela multiplier: {multiplier}; expected > 0"),
        ));
    }
    let nv = tok.int("number of vertical angles", 1, MAX_ANGLES as i64)? as usize;
    let nh = tok.int("number of horizontal angles", 1, MAX_ANGLES as i64)? as usize;
    crate::limits::check_memory(
        "number of candela values",
        &format!("{nh}x{nv}"),
        (nh * nv) as u128,
        16,
    )?;
    let kind = match tok.int("photometric type", 1, 3)? {
        1 => PhotometricType::C,
        2 => PhotometricType::B,
        _ => PhotometricType::A,
    };
    let units = tok.int("units type", 1, 2)?;
    let to_m = if units == 1 { 0.3048 } else { 1.0 };
    let width = tok.f64("luminous width")?;
    let length = tok.f64("luminous length")?;
    let height = tok.f64("luminous height")?;
    let ballast = tok.f64("ballast factor")?;
    if ballast <= 0.0 {
        return Err(Error::parse(
            source,
            tok.line(),
            format!("ballast factor: {ballast}; expected > 0"),
        ));
    }
    let third = tok.f64(if year >= 2019 {
        "file generation type"
    } else if year >= 2002 {
        "future use field"
    } else {
        "ballast-lamp photometric factor"
    })?;
    let input_watts = tok.f64("input watts")?;
    let (v, vline) = tok.many(nv, "vertical angle")?;
    tok.increasing(&v, vline, "vertical angles")?;
    let (h, hline) = tok.many(nh, "horizontal angle")?;
    tok.increasing(&h, hline, "horizontal angles")?;
    let cd_line = tok
        .toks
        .get(tok.pos)
        .map(|t| t.1)
        .unwrap_or(tok.last_line());
    let mut raw = Vec::with_capacity(nh * nv);
    for (ih, h_i) in h.iter().enumerate() {
        for (iv, v_i) in v.iter().enumerate() {
            let x = tok.f64(&format!(
                "candela value (horizontal {} of {nh}, vertical {} of {nv})",
                ih + 1,
                iv + 1
            ))?;
            if x < 0.0 {
                return Err(Error::parse(source, tok.line(), format!("candela value {x} at horizontal angle {}°, vertical angle {}° is negative; expected ≥ 0", h_i, v_i)));
            }
            raw.push(x);
        }
    }
    if tok.pos < tok.toks.len() {
        let (t, l) = tok.toks[tok.pos];
        return Err(Error::parse(source, l, format!("'{t}' after the {nh}×{nv} candela values (from line {cd_line}); expected the end of the file — is a count wrong?")));
    }
    let mut factor = multiplier * ballast;
    if year < 2002 {
        factor *= third;
        if third <= 0.0 {
            return Err(Error::parse(
                source,
                vline.saturating_sub(1),
                format!("ballast-lamp photometric factor: {third}; expected > 0"),
            ));
        }
    } else if year >= 2019 {
        notes.push(format!(
            "file generation type {third} recorded, not multiplied"
        ));
    }
    let tilt_factor = tilt.factor(lamp_tilt_deg);
    factor *= tilt_factor;
    let scaled: Vec<f64> = if factor == 1.0 {
        raw
    } else {
        raw.iter().map(|x| x * factor).collect()
    };
    let in_range = |what: &str, ok: bool, line: usize, expected: &str| -> Result<()> {
        if ok {
            Ok(())
        } else {
            Err(Error::parse(
                source,
                line,
                format!("{what}; expected {expected}"),
            ))
        }
    };
    let (grid, symmetry) = match kind {
        PhotometricType::C => {
            in_range(
                &format!("vertical angles {}–{}", v[0], v[nv - 1]),
                v[0] >= 0.0 && v[nv - 1] <= 180.0,
                vline,
                "Type C angles within 0–180°",
            )?;
            let (first, last) = (h[0], h[nh - 1]);
            let sym = if nh == 1 {
                Symmetry::Rotational
            } else if first == 0.0 && last == 90.0 {
                Symmetry::Quadrant
            } else if first == 0.0 && last == 180.0 {
                Symmetry::C0C180
            } else if first == 90.0 && last == 270.0 {
                Symmetry::C90C270
            } else if first == 0.0 && last > 180.0 && last <= 360.0 {
                Symmetry::None
            } else {
                return Err(Error::parse(source, hline, format!("horizontal angles {first}–{last}: expected an LM-63 Type C layout (one angle, 0–90, 0–180, 90–270 or 0–360)")));
            };
            if sym == Symmetry::Rotational && h[0] != 0.0 {
                notes.push(format!(
                    "single horizontal angle {}° read as rotational symmetry",
                    h[0]
                ));
            }
            let (hs, vals): (Vec<f64>, Vec<f64>) = if sym == Symmetry::None && last == 360.0 {
                let p0 = &scaled[..nv];
                let p360 = &scaled[(nh - 1) * nv..];
                if p0 != p360 {
                    notes.push(
                        "the 360° plane differs from the 0° plane; the 0° plane is used".into(),
                    );
                }
                (h[..nh - 1].to_vec(), scaled[..(nh - 1) * nv].to_vec())
            } else {
                (h.clone(), scaled)
            };
            let hs = if sym == Symmetry::Rotational {
                vec![0.0]
            } else {
                hs
            };
            let g = CandelaGrid::expand_type_c(sym, &hs, v.clone(), &vals)
                .map_err(|e| Error::parse(source, hline, e.to_string()))?;
            (g, sym)
        }
        _ => {
            in_range(
                &format!("vertical angles {}–{}", v[0], v[nv - 1]),
                v[0] >= -90.0 && v[nv - 1] <= 90.0,
                vline,
                "Type A/B angles within −90–90°",
            )?;
            let (first, last) = (h[0], h[nh - 1]);
            if first == 0.0 && last <= 90.0 && nh > 1 {
                let mut hh: Vec<f64> = h.iter().rev().filter(|x| **x > 0.0).map(|x| -x).collect();
                let mut vals = Vec::with_capacity(scaled.len() * 2);
                for i in (1..nh).rev() {
                    vals.extend_from_slice(&scaled[i * nv..(i + 1) * nv]);
                }
                hh.extend_from_slice(&h);
                vals.extend_from_slice(&scaled);
                (
                    CandelaGrid::new(kind, hh, v.clone(), vals)
                        .map_err(|e| Error::parse(source, hline, e.to_string()))?,
                    Symmetry::LateralAB,
                )
            } else if first >= -90.0 && last <= 90.0 {
                (
                    CandelaGrid::new(kind, h.clone(), v.clone(), scaled)
                        .map_err(|e| Error::parse(source, hline, e.to_string()))?,
                    Symmetry::NoneAB,
                )
            } else {
                return Err(Error::parse(
                    source,
                    hline,
                    format!(
                        "horizontal angles {first}–{last}: expected 0–90 or −90–90 for Type A/B"
                    ),
                ));
            }
        }
    };
    let shape = if width == 0.0 && length == 0.0 && height == 0.0 {
        OpeningShape::Point
    } else if width < 0.0 && length < 0.0 && height < 0.0 {
        OpeningShape::Sphere
    } else if width < 0.0 && height > 0.0 || (height < 0.0 && width >= 0.0) {
        OpeningShape::Cylinder
    } else if width < 0.0 && (length == 0.0 || length == width) {
        OpeningShape::Circular
    } else if width < 0.0 || length < 0.0 {
        OpeningShape::Elliptical
    } else {
        OpeningShape::Rectangular
    };
    let length_m = if shape == OpeningShape::Circular && length == 0.0 {
        width.abs()
    } else {
        length.abs()
    } * to_m;
    let opening = LuminousOpening {
        length_m,
        width_m: width.abs() * to_m,
        height_m: height.abs() * to_m,
        shape,
    };
    if units == 1 {
        notes.push("dimensions in feet converted to metres".into());
    }
    let lamp_flux_lm = (lumens > 0.0).then_some(n_lamps as f64 * lumens);
    Ok(PhotometricFile {
        format: FileFormat::Ies,
        version,
        keywords,
        lamps: vec![LampSet {
            count: n_lamps,
            kind: String::new(),
            flux_lm: lamp_flux_lm.unwrap_or(-1.0),
            colour_temperature: String::new(),
            colour_rendering: String::new(),
            watts: input_watts,
        }],
        direct_ratios: Vec::new(),
        ldt_type_indicator: 0,
        input_watts,
        notes,
        photometry: Photometry {
            grid,
            symmetry,
            lamp_flux_lm,
            declared_luminaire_flux_lm: None,
            declared_lor_percent: None,
            declared_dff_percent: None,
            opening,
            tilt,
            tilt_applied: (lamp_tilt_deg, tilt_factor),
        },
    })
}

/// Reads an IES file; a `TILT=<file>` is resolved relative to the IES file's directory.
pub fn read_ies(path: &Path, lamp_tilt_deg: f64) -> Result<PhotometricFile> {
    let (bytes, source) = super::read_input(path)?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let loader =
        move |name: &str| -> Result<(Vec<u8>, String)> { super::read_input(&dir.join(name)) };
    parse_ies(&bytes, &source, &loader, lamp_tilt_deg)
}

/// The planes (indices into `grid.h_deg`) a file of this symmetry stores.
pub(crate) fn stored_planes(grid: &CandelaGrid, symmetry: Symmetry) -> Vec<usize> {
    match symmetry {
        Symmetry::LateralAB => (0..grid.h_deg.len())
            .filter(|&i| grid.h_deg[i] >= 0.0)
            .collect(),
        s => (0..grid.h_deg.len())
            .filter(|&i| s.stores(grid.h_deg[i]))
            .collect(),
    }
}

fn push_wrapped(out: &mut String, values: impl Iterator<Item = f64>) {
    let mut line_len = 0;
    for x in values {
        let s = format!("{x}");
        if line_len > 0 && line_len + s.len() + 1 > 100 {
            out.push('\n');
            line_len = 0;
        }
        if line_len > 0 {
            out.push(' ');
            line_len += 1;
        }
        out.push_str(&s);
        line_len += s.len();
    }
    out.push('\n');
}

/// Writes LM-63-2019 text for the file (see the module docs). `tool` goes into a `[_LUMIFIT]`
/// keyword.
pub fn write_ies(file: &PhotometricFile, tool: &str) -> Result<String> {
    let p = &file.photometry;
    let g = &p.grid;
    let mut out = String::from("IES:LM-63-2019\n");
    let required = ["TEST", "TESTLAB", "ISSUEDATE", "MANUFAC"];
    for key in required {
        if file.keyword(key).is_none() {
            out.push_str(&format!("[{key}] unknown\n"));
        }
    }
    for (k, v) in &file.keywords {
        let key = if k == "LABEL" { "OTHER" } else { k.as_str() };
        let mut parts = v.split('\n');
        out.push_str(&format!("[{key}] {}\n", parts.next().unwrap_or("")));
        for more in parts {
            out.push_str(&format!("[MORE] {more}\n"));
        }
    }
    out.push_str(&format!("[_LUMIFIT] written by {tool}"));
    if let Tilt::Table { source, .. } = &p.tilt {
        out.push_str(&format!(
            "; TILT={source} applied at lamp tilt {}° (factor {})",
            p.tilt_applied.0, p.tilt_applied.1
        ));
    }
    out.push('\n');
    out.push_str("TILT=NONE\n");
    let planes = stored_planes(g, p.symmetry);
    let mut h: Vec<f64> = planes.iter().map(|&i| g.h_deg[i]).collect();
    let full_circle = p.symmetry == Symmetry::None;
    if full_circle {
        h.push(360.0);
    }
    let (kind, lumens) = (
        match g.kind {
            PhotometricType::C => 1,
            PhotometricType::B => 2,
            PhotometricType::A => 3,
        },
        p.lamp_flux_lm
            .map(|l| format!("{l}"))
            .unwrap_or_else(|| "-1".into()),
    );
    let o = &p.opening;
    let (w, l, hgt) = match o.shape {
        OpeningShape::Point => (0.0, 0.0, 0.0),
        OpeningShape::Rectangular => (o.width_m, o.length_m, o.height_m),
        OpeningShape::Circular | OpeningShape::Elliptical => (-o.width_m, -o.length_m, 0.0),
        OpeningShape::Cylinder => (-o.width_m, -o.length_m, o.height_m),
        OpeningShape::Sphere => (-o.width_m, -o.length_m, -o.height_m),
    };
    out.push_str(&format!(
        "1 {lumens} 1 {} {} {kind} 2 {w} {l} {hgt}\n",
        g.v_deg.len(),
        h.len()
    ));
    out.push_str(&format!("1 1.00001 {}\n", file.input_watts));
    push_wrapped(&mut out, g.v_deg.iter().copied());
    push_wrapped(&mut out, h.iter().copied());
    let nv = g.nv();
    let mut rows: Vec<usize> = planes.clone();
    if full_circle {
        rows.push(planes[0]);
    }
    for i in rows {
        push_wrapped(&mut out, g.cd[i * nv..(i + 1) * nv].iter().copied());
    }
    if out.lines().any(|l| l.len() > 256) {
        return Err(Error::invalid(
            "IES writer",
            "a keyword line is longer than LM-63's 256 characters",
        ));
    }
    Ok(out)
}
