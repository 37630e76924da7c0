//! The reference tables embedded from `calib/` equal colour-science's bit for bit: the SHA-256 of
//! the parsed doubles matches the digest colour_reference.py computed from colour's own arrays.

use std::path::PathBuf;

use lumifit::calib;
use lumifit::table::NumericTable;
use sha2::{Digest, Sha256};

fn digest(t: &NumericTable) -> String {
    let mut h = Sha256::new();
    for r in 0..t.n_rows() {
        for c in &t.columns {
            h.update(c[r].to_le_bytes());
        }
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

fn fixture() -> serde_json::Value {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/calib_digests.json");
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

#[test]
fn cmf_tables_equal_colour_bit_for_bit() {
    let f = fixture();
    for c in calib::CmfTable::ALL {
        let key = format!("cmfs/{}", c.key());
        let want = &f["tables"][&key];
        let t = c.table();
        assert_eq!(
            t.n_rows() as u64,
            want["rows"].as_u64().unwrap(),
            "{key} rows"
        );
        assert_eq!(
            digest(t),
            want["sha256"].as_str().unwrap(),
            "{key} differs from colour's table"
        );
    }
}

#[test]
fn illuminant_tables_equal_colour_bit_for_bit() {
    let f = fixture();
    for name in calib::illuminant_names() {
        let key = format!("illuminants/{name}");
        let want = &f["tables"][&key];
        let t = calib::illuminant_table(name).unwrap();
        assert_eq!(
            digest(t),
            want["sha256"].as_str().unwrap(),
            "{key} differs from colour's table"
        );
    }
}
