//! `phos fit-decay --per-pixel --shard i/n` and `phos merge-maps`: four shards merged give map
//! files byte-identical to a single run; missing, duplicated, foreign and corrupted shards are
//! refused with exit code 2 naming the shard; the Slurm and Kubernetes files of
//! `scripts/scale-out/` are syntactically valid and run the commands as documented.

mod common;

use common::{assert_rejected, lumifit, p};
use std::path::Path;

fn ok(args: &[&str]) {
    let o = lumifit(args);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A 64×48, 37-frame halves series and the per-pixel flags shared by every run (8 px tiles:
/// 6 rows of tiles, so 4 shards of 1–2 rows each).
fn series(dir: &Path) -> String {
    ok(&[
        "synth",
        "phos-decay",
        "--material",
        "green_paint",
        "--layout",
        "halves",
        "--size",
        "64x48",
        "--seed",
        "5",
        "--out",
        &p(dir, "s"),
    ]);
    p(dir, "s/manifest.csv")
}

fn tifs(dir: &Path) -> Vec<(String, Vec<u8>)> {
    tifs_ext(dir, "tif")
}

fn tifs_ext(dir: &Path, ext: &str) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().to_string(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

#[test]
fn four_merged_shards_are_byte_identical_to_a_single_run_and_bad_shards_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let s = series(d.path());
    let single = p(d.path(), "single");
    ok(&[
        "phos",
        "fit-decay",
        &s,
        "--per-pixel",
        "--tile",
        "8",
        "--out",
        &single,
    ]);
    let mut shards = Vec::new();
    for i in 0..4 {
        let out = p(d.path(), &format!("shard-{i}"));
        ok(&[
            "phos",
            "fit-decay",
            &s,
            "--per-pixel",
            "--tile",
            "8",
            "--shard",
            &format!("{i}/4"),
            "--out",
            &out,
        ]);
        assert!(Path::new(&out).join("shard.json").is_file());
        shards.push(out);
    }
    let merged = p(d.path(), "merged");
    // in any order
    let mut args = vec!["phos", "merge-maps"];
    args.extend([&shards[2], &shards[0], &shards[3], &shards[1]].map(|s| s.as_str()));
    args.extend(["--out", &merged]);
    ok(&args);
    let (a, b) = (tifs(Path::new(&single)), tifs(Path::new(&merged)));
    assert_eq!(
        a.len(),
        12,
        "{:?}",
        a.iter().map(|x| &x.0).collect::<Vec<_>>()
    );
    assert_eq!(
        a.iter().map(|x| &x.0).collect::<Vec<_>>(),
        b.iter().map(|x| &x.0).collect::<Vec<_>>()
    );
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(
            x == y,
            "{name} differs between the single run and the merge"
        );
    }
    // the 16-bit previews too, and the preset that references the maps
    let (pa, pb) = (
        tifs_ext(&Path::new(&single).join("previews"), "png"),
        tifs_ext(&Path::new(&merged).join("previews"), "png"),
    );
    assert_eq!(pa.len(), 11);
    assert!(pa == pb, "the previews differ");
    for dir in [&single, &merged] {
        let preset = Path::new(dir).join("preset.json");
        let m = lumifit::preset::read_material(&preset).unwrap();
        let ph = m.phosphorescence.unwrap();
        let tex = &ph.extra["maps"]["textures"];
        for plane in ["k1_per_s", "a1", "n_states", "rms", "spectrum_rgb"] {
            let t = tex[plane]["texture"].as_str().unwrap();
            assert!(Path::new(dir).join(t).is_file(), "{plane}: {t}");
            assert!(tex[plane]["meaning"]
                .as_str()
                .is_some_and(|s| !s.is_empty()));
        }
        assert_eq!(tex["k1_per_s"]["unit"], "1/s");
        let prev = tex["k1_per_s"]["preview"].as_str().unwrap();
        let img = image::open(Path::new(dir).join(prev)).unwrap();
        assert_eq!(img.color(), image::ColorType::L16);
        // the median fastest rate of the halves series is green paint's 0.227 /s
        let k1 = ph.states[0].k_r_per_s;
        assert!((k1 / 0.227 - 1.0).abs() < 0.05, "{k1}");
    }
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(Path::new(&merged).join("summary.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(summary["blocks"], 64 * 48);
    assert_eq!(summary["failed"], 0);

    // a missing shard
    let out2 = p(d.path(), "m2");
    let o = lumifit(&[
        "phos",
        "merge-maps",
        &shards[0],
        &shards[1],
        &shards[2],
        "--out",
        &out2,
    ]);
    assert_rejected(&o, &["shard 3/4 is missing"]);
    // a duplicated shard
    let o = lumifit(&[
        "phos",
        "merge-maps",
        &shards[0],
        &shards[1],
        &shards[2],
        &shards[2],
        "--out",
        &out2,
    ]);
    assert_rejected(&o, &["shard 2/4 is given twice", "shard-2"]);
    // a shard of another run (other fit options)
    let foreign = p(d.path(), "foreign-1");
    ok(&[
        "phos",
        "fit-decay",
        &s,
        "--per-pixel",
        "--tile",
        "8",
        "--states",
        "2",
        "--shard",
        "1/4",
        "--out",
        &foreign,
    ]);
    let o = lumifit(&[
        "phos",
        "merge-maps",
        &shards[0],
        &foreign,
        &shards[2],
        &shards[3],
        "--out",
        &out2,
    ]);
    assert_rejected(&o, &["foreign-1", "not part of the same run"]);
    // a corrupted data file
    let data = Path::new(&shards[3]).join("maps.f32le");
    let mut bytes = std::fs::read(&data).unwrap();
    bytes[5] ^= 1;
    std::fs::write(&data, &bytes).unwrap();
    let o = lumifit(&[
        "phos",
        "merge-maps",
        &shards[0],
        &shards[1],
        &shards[2],
        &shards[3],
        "--out",
        &out2,
    ]);
    assert_rejected(&o, &["shard-3", "maps.f32le", "SHA-256"]);
    assert!(!Path::new(&out2).exists(), "a refused merge writes nothing");
    // more shards than tile rows
    let o = lumifit(&[
        "phos",
        "fit-decay",
        &s,
        "--per-pixel",
        "--tile",
        "8",
        "--shard",
        "0/7",
        "--out",
        &out2,
    ]);
    assert_rejected(&o, &["--shard", "at most 6 shards"]);
    let o = lumifit(&[
        "phos",
        "fit-decay",
        &s,
        "--per-pixel",
        "--shard",
        "4/4",
        "--out",
        &out2,
    ]);
    assert_rejected(&o, &["--shard", "0 ≤ i < n"]);
}

fn repo(path: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

#[test]
fn the_slurm_script_passes_bash_syntax_check_and_runs_the_shard_and_merge_commands() {
    let script = repo("scripts/scale-out/slurm-per-pixel.sh");
    let text = std::fs::read_to_string(&script).unwrap();
    assert!(text.contains("--shard \"$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT\""));
    assert!(text.contains("phos merge-maps"));
    match std::process::Command::new("bash")
        .arg("-n")
        .arg(&script)
        .output()
    {
        Ok(o) => assert!(
            o.status.success(),
            "bash -n: {}",
            String::from_utf8_lossy(&o.stderr)
        ),
        Err(e) => eprintln!("skipped bash -n (no bash: {e})"),
    }
}

#[test]
fn the_kubernetes_manifests_parse_as_indexed_and_merge_jobs() {
    use yaml_rust2::YamlLoader;
    let text = std::fs::read_to_string(repo("scripts/scale-out/k8s-per-pixel.yaml")).unwrap();
    let docs = YamlLoader::load_from_str(&text).unwrap();
    assert_eq!(docs.len(), 1);
    let job = &docs[0];
    assert_eq!(job["kind"].as_str(), Some("Job"));
    assert_eq!(job["spec"]["completionMode"].as_str(), Some("Indexed"));
    let n = job["spec"]["completions"].as_i64().unwrap();
    let c = &job["spec"]["template"]["spec"]["containers"][0];
    let shards = c["env"]
        .as_vec()
        .unwrap()
        .iter()
        .find(|e| e["name"].as_str() == Some("SHARDS"))
        .and_then(|e| e["value"].as_str())
        .unwrap();
    assert_eq!(
        shards.parse::<i64>().unwrap(),
        n,
        "SHARDS must equal completions"
    );
    let args = c["args"][0].as_str().unwrap();
    assert!(
        args.contains("--shard \"${JOB_COMPLETION_INDEX}/${SHARDS}\""),
        "{args}"
    );
    let merge = std::fs::read_to_string(repo("scripts/scale-out/k8s-merge.yaml")).unwrap();
    let docs = YamlLoader::load_from_str(&merge).unwrap();
    let args = docs[0]["spec"]["template"]["spec"]["containers"][0]["args"][0]
        .as_str()
        .unwrap();
    assert!(args.contains("phos merge-maps"), "{args}");
}
