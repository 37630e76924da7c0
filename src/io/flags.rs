//! Values typed on the command line that are not file names: comma-separated tuples of numbers
//! (`--center 0,2.5,0`, `--rect 1,0.5`) and ROI rectangles. Every error names the flag, what was
//! given and what was expected ([`Error::Flag`]).

use crate::capture::Roi;
use crate::error::{Error, Result};

/// Parses `a,b,c` into three finite numbers, naming the flag on error.
pub fn parse_triplet(flag: &str, s: &str) -> Result<[f64; 3]> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(Error::flag(
            flag,
            format!("expected three comma-separated numbers like 50,10,-20, got '{s}'"),
        ));
    }
    let mut out = [0.0; 3];
    for (i, p) in parts.iter().enumerate() {
        let v: f64 = p
            .parse()
            .map_err(|_| Error::flag(flag, format!("component {} '{p}' is not a number", i + 1)))?;
        if !v.is_finite() {
            return Err(Error::flag(
                flag,
                format!("component {} must be finite, got '{p}'", i + 1),
            ));
        }
        out[i] = v;
    }
    Ok(out)
}

/// Parses `a,b` into two numbers, naming the flag on error (the parse error is the cause).
pub fn parse_pair(flag: &str, s: &str) -> Result<(f64, f64)> {
    let v: Vec<&str> = s.split(',').map(str::trim).collect();
    let (Some(a), Some(b), 2) = (v.first(), v.get(1), v.len()) else {
        return Err(Error::flag(
            flag,
            format!("expected two comma-separated numbers like 1,0.5, got '{s}'"),
        ));
    };
    let number = |t: &str| -> Result<f64> {
        t.parse()
            .map_err(|e: std::num::ParseFloatError| Error::Flag {
                flag: flag.to_string(),
                message: format!("'{t}' is not a number"),
                source: Some(Box::new(e)),
            })
    };
    Ok((number(a)?, number(b)?))
}

/// `--roi x,y,w,h` as a rectangle `[x, y, w, h]`.
pub fn parse_rect(s: &str) -> Result<[usize; 4]> {
    match Roi::parse_rect(s)? {
        Roi::Rect { x, y, w, h } => Ok([x, y, w, h]),
        _ => Err(Error::flag("--roi", "expected a rectangle x,y,w,h")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triplet_names_the_flag_and_the_bad_component() {
        assert_eq!(parse_triplet("--up", "0, 1 ,2").unwrap(), [0.0, 1.0, 2.0]);
        let e = parse_triplet("--up", "0,x,2").unwrap_err().to_string();
        assert_eq!(e, "--up: component 2 'x' is not a number");
        let e = parse_triplet("--up", "0,inf,2").unwrap_err().to_string();
        assert_eq!(e, "--up: component 2 must be finite, got 'inf'");
        assert!(parse_triplet("--up", "1,2").is_err());
    }

    #[test]
    fn pair_keeps_the_parse_error_as_its_cause() {
        assert_eq!(parse_pair("--rect", "1,0.5").unwrap(), (1.0, 0.5));
        let e = parse_pair("--rect", "1,z").unwrap_err();
        assert_eq!(e.to_string(), "--rect: 'z' is not a number");
        assert!(std::error::Error::source(&e).is_some());
        let e = parse_pair("--rect", "1").unwrap_err().to_string();
        assert!(e.contains("expected two comma-separated numbers"), "{e}");
    }
}
