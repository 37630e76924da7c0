//! Upper bounds for every size a user can type (bands, grid points, image size, frames).
//!
//! A size is checked against an estimate of the memory it needs *before* anything is allocated,
//! so an absurd request is an error naming the flag, the estimate and the limit instead of an
//! allocation failure (exit 134) or a run of hours.
//!
//! The default budget is [`DEFAULT_MEMORY_MIB`]; the environment variable `LUMIFIT_MEMORY_GB`
//! overrides it (a positive number of GiB).

use crate::error::{Error, Result};

/// Default memory budget for one allocation-heavy request: 16 GiB, so a run fits a 24 GiB machine
/// with room for the rest of the process.
pub const DEFAULT_MEMORY_MIB: u64 = 16 * 1024;

/// The memory budget in MiB (`LUMIFIT_MEMORY_GB` if set to a positive number, else the default).
pub fn memory_budget_mib() -> u64 {
    std::env::var("LUMIFIT_MEMORY_GB")
        .ok()
        .and_then(|v| v.trim().parse::<f64>().ok())
        .filter(|g| g.is_finite() && *g > 0.0)
        .map(|g| (g * 1024.0) as u64)
        .unwrap_or(DEFAULT_MEMORY_MIB)
}

/// Checks that `count` elements of `bytes_each` bytes fit the memory budget. `what` names the
/// flag or field, `requested` says the size as the user typed it.
pub fn check_memory(what: &str, requested: &str, count: u128, bytes_each: u128) -> Result<()> {
    let needed = count.saturating_mul(bytes_each);
    let needed_mib = (needed / (1024 * 1024)) as u64;
    let limit_mib = memory_budget_mib();
    if needed_mib > limit_mib {
        return Err(Error::TooLarge {
            what: what.to_string(),
            requested: requested.to_string(),
            needed_mib,
            limit_mib,
            hint: "ask for less, or raise the budget with LUMIFIT_MEMORY_GB".to_string(),
        });
    }
    Ok(())
}

/// Checks a count against a hard upper bound that is not about memory but about work or meaning
/// (e.g. more LVF bands than a filter can resolve).
pub fn check_count(what: &str, value: usize, max: usize, why: &str) -> Result<()> {
    if value > max {
        return Err(Error::invalid(
            what,
            format!("{value} is over the limit of {max} ({why})"),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sixty_thousand_square_image_is_refused_with_numbers() {
        let e = check_memory("--size", "60000x60000", 60000 * 60000 * 3, 8).unwrap_err();
        let s = e.to_string();
        assert!(s.contains("--size") && s.contains("MiB"), "{s}");
    }

    #[test]
    fn a_small_request_passes() {
        check_memory("--bands", "31", 31, 8).unwrap();
        check_count("--bands", 31, 1000, "resolution").unwrap();
        assert!(check_count("--bands", 100_000_000, 1000, "resolution").is_err());
    }
}
