//! `pmon evaluate` over a folder of recordings: one task per recording and part, a broken recording reported by
//! name without stopping the run, the pooled curves equal to the sums of the per-task counts, the same bytes
//! with 1 and 2 threads, and a resumed run (results deleted, run again) equal to the whole one.

mod common;
use common::{data_dir, pmon, text};
use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Output;

use serde_json::Value;

/// Two simulated recordings (2 s each) and a broken one (its frames file is not JSON).
fn recordings(root: &Path) -> PathBuf {
    let dir = root.join("recs");
    for (name, scenario, seed) in [("a-street", "pedestrians", "3"), ("b-crossing", "intersection", "4")] {
        let out = dir.join(name);
        let o = pmon(&[
            "simulate",
            "--scenario",
            scenario,
            "--seed",
            seed,
            "--duration-s",
            "2",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", text(&o));
    }
    let broken = dir.join("c-broken");
    fs::create_dir_all(&broken).unwrap();
    fs::copy(dir.join("a-street/recording.json"), broken.join("recording.json")).unwrap();
    fs::write(broken.join("frames.jsonl"), "{\"this is\": not json\n").unwrap();
    dir
}

/// results.json and every CSV of a report folder, by file name.
fn report_bytes(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    for e in fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if name == "results.json" || name.ends_with(".csv") {
            out.insert(name, fs::read(&p).unwrap());
        }
    }
    out
}

fn evaluate(src: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["evaluate", src.to_str().unwrap(), "--smoke", "--seed", "5", "--out", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    pmon(&args)
}

#[test]
fn evaluate_reports_bad_logs_pools_counts_and_resumes_to_the_same_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let src = recordings(tmp.path());
    let a = tmp.path().join("a");
    let o = evaluate(&src, &a, &["--threads", "1"]);
    // A failed task: exit status 1, the report written anyway.
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("FAILED c-broken"), "{}", text(&o));
    let res: Value = serde_json::from_slice(&fs::read(a.join("results.json")).unwrap()).unwrap();
    let tasks = res["tasks"].as_array().unwrap();
    assert_eq!(tasks.len(), 6, "3 recordings x 2 parts");
    let failed = res["failed"].as_array().unwrap();
    assert_eq!(failed.len(), 2, "{failed:?}");
    for f in failed {
        assert_eq!(f["log"], "c-broken");
        assert!(f["error"].as_str().unwrap().contains("frames.jsonl"), "the error names the file: {f}");
    }
    let figures = res["real_data"]["figures"].as_array().unwrap();
    let ids: Vec<&str> = figures.iter().map(|f| f["spec"]["id"].as_str().unwrap()).collect();
    assert_eq!(ids, ["real_position_recording", "real_speed_errors_recording", "real_random_position_recording"]);

    // The pooled points are the sums of the per-task counts in the run folder.
    let mut sums: BTreeMap<(String, String, u64), (u64, u64)> = BTreeMap::new();
    let mut ok = 0;
    for e in fs::read_dir(tmp.path().join("a.run/results")).unwrap() {
        let r: Value = serde_json::from_slice(&fs::read(e.unwrap().path()).unwrap()).unwrap();
        let Some(out) = r["outcome"].get("ok") else { continue };
        ok += 1;
        for f in out["figures"].as_array().unwrap() {
            for c in f["curves"].as_array().unwrap() {
                for p in c["points"].as_array().unwrap() {
                    let key = (
                        f["spec"]["id"].as_str().unwrap().to_string(),
                        c["label"].as_str().unwrap().to_string(),
                        p[0].as_f64().unwrap().to_bits(),
                    );
                    let s = sums.entry(key).or_default();
                    s.0 += p[1].as_u64().unwrap();
                    s.1 += p[2].as_u64().unwrap();
                }
            }
        }
    }
    assert_eq!(ok, 4);
    let mut checked = 0;
    for f in figures {
        for c in f["curves"].as_array().unwrap() {
            for p in c["points"].as_array().unwrap() {
                let key = (
                    f["spec"]["id"].as_str().unwrap().to_string(),
                    c["label"].as_str().unwrap().to_string(),
                    p["x"].as_f64().unwrap().to_bits(),
                );
                let (k, n) = sums[&key];
                assert_eq!((p["rate"]["k"].as_u64().unwrap(), p["rate"]["n"].as_u64().unwrap()), (k, n), "{key:?}");
                checked += usize::from(n > 0);
            }
        }
    }
    assert!(checked > 10, "only {checked} points with counts");

    // Two threads: the same bytes.
    let b = tmp.path().join("b");
    let o = evaluate(&src, &b, &["--threads", "2"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert_eq!(report_bytes(&a), report_bytes(&b));

    // Resume: one finished result deleted; the rerun runs it and the failed ones only, and gives the same bytes.
    fs::remove_file(tmp.path().join("b.run/results/recording-a-street-tracks.json")).unwrap();
    let o = evaluate(&src, &b, &["--threads", "2"]);
    assert!(text(&o).contains("3 finished in") && text(&o).contains("3 to run"), "{}", text(&o));
    assert_eq!(report_bytes(&a), report_bytes(&b));

    // Another plan in the same run folder is refused (not silently mixed).
    let o = pmon(&["evaluate", src.to_str().unwrap(), "--smoke", "--seed", "6", "--out", b.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("another plan"), "{}", text(&o));
}

#[test]
fn evaluate_refuses_a_source_without_logs() {
    let tmp = tempfile::tempdir().unwrap();
    let empty = tmp.path().join("empty");
    fs::create_dir_all(&empty).unwrap();
    let o = pmon(&["evaluate", empty.to_str().unwrap(), "--out", tmp.path().join("o").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("no log found"), "{}", text(&o));
    let o = pmon(&["evaluate", "av2:/nonexistent/pmon", "--out", tmp.path().join("o").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("not found"), "{}", text(&o));
}

#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn evaluate_av2_val_runs_every_log() {
    let Some(data) = data_dir() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let src = format!("av2:{}", data.join("av2/sensor/val").display());
    let out = tmp.path().join("av2");
    let o = pmon(&["evaluate", &src, "--smoke", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    let res: Value = serde_json::from_slice(&fs::read(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(res["tasks"].as_array().unwrap().len(), 4, "2 logs x 2 parts");
    assert_eq!(res["failed"].as_array().unwrap().len(), 0);
    let mut ids: Vec<&str> =
        res["real_data"]["figures"].as_array().unwrap().iter().map(|f| f["spec"]["id"].as_str().unwrap()).collect();
    ids.sort_unstable();
    assert_eq!(ids, ["real_position_av2", "real_random_position_av2", "real_speed_errors_av2"]);
    // The log without LiDAR says so; its tracks are in the plausibility figures (pooled over 2 logs).
    let notes = res["real_data"]["notes"].as_array().unwrap();
    assert!(notes.iter().any(|n| n.as_str().unwrap().contains("3b3570b4") && n.as_str().unwrap().contains("no frame")));
    let speed =
        res["real_data"]["figures"].as_array().unwrap().iter().find(|f| f["spec"]["id"] == "real_speed_errors_av2");
    assert!(speed.unwrap()["spec"]["title"].as_str().unwrap().contains("pooled over 2 logs"));
}
