//! `run_bench` produces a complete report (figures are not asserted: they depend on the machine).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use pmon_bench::{run_bench, BenchError, BenchOptions, BenchReport, RuleSwitches, Timing};
use pmon_monitor::{MonitorParams, Stage};

fn quick() -> BenchOptions {
    BenchOptions {
        iterations: 3,
        max_seconds_per_case: 1.0,
        real_data: false,
        worst_case: false,
        ..BenchOptions::default()
    }
}

#[test]
fn report_has_every_case_stage_and_goal_and_round_trips_through_json() {
    let report = run_bench(&quick()).unwrap();
    let names: Vec<&str> = report.cases.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "synthetic-64/0.5m",
            "synthetic-64/0.2m",
            "synthetic-64/0.1m",
            "synthetic-64/0.2m/200m",
            "synthetic-32/0.5m",
            "objects-30/no-cloud",
            "objects-100/no-cloud",
            "objects-300/no-cloud",
            "objects-1000/no-cloud",
            "objects-30/no-cloud/calibrated",
            "objects-30/steady",
            "objects-30/steady/calibrated",
        ]
    );
    for c in &report.cases {
        assert_eq!(c.samples, 3, "{}", c.name);
        let stages: Vec<&str> = c.stages.iter().map(|s| s.stage.as_str()).collect();
        let expected: Vec<&str> = Stage::ALL.iter().map(|s| s.name()).collect();
        assert_eq!(stages, expected);
        assert!(c.total.median_us > 0.0 && c.total.p10_us <= c.total.median_us && c.total.median_us <= c.total.p90_us);
        assert_eq!(c.floor.is_some(), c.points > 0, "{}", c.name);
        assert_eq!(c.native_floor.is_some(), c.points > 0, "{}", c.name);
        assert_eq!(c.sensor_over_native_floor.is_some(), c.points > 0, "{}", c.name);
        let t = c.sensor_checks;
        assert!(t.p90_us <= t.p99_us && t.p99_us <= t.max_us, "{}: {t:?}", c.name);
    }
    let c64 = &report.cases[0];
    assert_eq!((c64.points, c64.objects, c64.grid_cells), (120_000, 100, 40_000));
    assert_eq!(report.cases[2].grid_cells, 1_000_000);
    assert_eq!(report.cases[4].points, 34_720);
    // 7, and per 0.5 m case with a cloud (synthetic 64- and 32-beam) the native-floor and p99 goals, and on Linux
    // the p99 in the thread's CPU time.
    let cpu_lines = if cfg!(target_os = "linux") { 2 } else { 0 };
    assert_eq!(report.goals.len(), 11 + cpu_lines, "{:?}", report.goals);
    assert!(report.goals.iter().any(|g| g.goal == "synthetic-64/0.5m: sensor checks <= 10x the native floor"));
    assert!(report.paper.iter().any(|p| p.paper_us == 12_000.0 && p.case == "synthetic-64/0.5m"));

    let json = serde_json::to_string(&report).unwrap();
    let back: BenchReport = serde_json::from_str(&json).unwrap();
    // serde_json parses floats to within an ulp, not always exactly: compare everything else exactly.
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(1.0);
    assert_eq!((&back.machine, &back.goals, &back.notes), (&report.machine, &report.goals, &report.notes));
    assert_eq!(back.cases.len(), report.cases.len());
    for (b, r) in back.cases.iter().zip(&report.cases) {
        assert_eq!(
            (&b.name, b.points, b.objects, b.grid_cells, b.samples),
            (&r.name, r.points, r.objects, r.grid_cells, r.samples)
        );
        for (tb, tr) in b.stages.iter().zip(&r.stages).map(|(x, y)| (x.timing, y.timing)).chain([(b.total, r.total)]) {
            assert!(close(tb.median_us, tr.median_us) && close(tb.p10_us, tr.p10_us) && close(tb.p90_us, tr.p90_us));
        }
    }

    let table = report.to_table();
    for name in names {
        assert!(table.contains(name), "table lacks {name}");
    }
    for heading in
        ["Frames", "Median per stage", "Spread p10-p90", "p99", "native", "Paper", "Goals", "i9-7900X", "Atom C3934"]
    {
        assert!(table.contains(heading), "table lacks {heading}:\n{table}");
    }
    assert!(table.is_ascii());
}

#[test]
fn zero_iterations_is_an_error() {
    let err = run_bench(&BenchOptions { iterations: 0, ..quick() }).unwrap_err();
    assert!(matches!(err, BenchError::Options(_)), "{err}");
    let err = run_bench(&BenchOptions { max_seconds_per_case: f64::NAN, ..quick() }).unwrap_err();
    assert!(err.to_string().contains("max_seconds_per_case"), "{err}");
}

#[test]
fn malformed_real_sweep_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let velodyne = dir.path().join("kitti/object/training/velodyne");
    std::fs::create_dir_all(&velodyne).unwrap();
    std::fs::write(velodyne.join("000000.bin"), [0u8; 17]).unwrap();
    let err =
        run_bench(&BenchOptions { data_dir: Some(dir.path().to_path_buf()), real_data: true, ..quick() }).unwrap_err();
    let text = err.to_string();
    assert!(text.contains("000000.bin") && text.contains("whole number"), "{text}");
}

#[test]
fn percentiles_are_nearest_rank() {
    let samples: Vec<f64> = (1..=10).rev().map(f64::from).collect();
    let t = Timing::of(&samples);
    assert_eq!((t.p10_us, t.median_us, t.p90_us, t.p99_us, t.max_us), (1.0, 5.5, 9.0, 10.0, 10.0));
    let many: Vec<f64> = (1..=1000).map(f64::from).collect();
    assert_eq!((Timing::of(&many).p99_us, Timing::of(&many).max_us), (990.0, 1000.0));
    assert_eq!(Timing::of(&[]), Timing::default());
    assert_eq!(Timing::of(&[2.0, 1.0, 3.0]).median_us, 2.0);
}

#[test]
fn only_selects_cases_by_name() {
    let report =
        run_bench(&BenchOptions { only: vec!["synthetic-32".into(), "objects-30/".into()], ..quick() }).unwrap();
    let names: Vec<&str> = report.cases.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "synthetic-32/0.5m",
            "objects-30/no-cloud",
            "objects-30/no-cloud/calibrated",
            "objects-30/steady",
            "objects-30/steady/calibrated"
        ]
    );
}

/// The steady-traffic cases raise no alarm (their frames cycle without a jump); the 6-frame cycle of
/// `objects-30/no-cloud` jumps back at every wrap and alarms. The 5 us goal is judged on the steady case, with the
/// worst case beside it.
#[test]
fn steady_traffic_raises_no_alarm_and_carries_the_goal() {
    // 700 timed checks after the warm-up of one period (300 frames): the wrap at frame 300 and at 600 included.
    let report = run_bench(&BenchOptions { iterations: 700, only: vec!["objects-30/".into()], ..quick() }).unwrap();
    let case = |name: &str| report.cases.iter().find(|c| c.name == name).unwrap();
    for name in ["objects-30/steady", "objects-30/steady/calibrated"] {
        let c = case(name);
        assert_eq!(c.samples, 700, "{name}");
        assert_eq!(c.frames, pmon_bench::frames::STEADY_PERIOD_FRAMES as usize);
        assert_eq!(c.motion_states, 700 * 30, "{name}: every state judged");
        assert_eq!(c.motion_alarms, 0, "{name}");
    }
    for name in ["objects-30/no-cloud", "objects-30/no-cloud/calibrated"] {
        let c = case(name);
        assert!(c.motion_alarms * 20 > c.motion_states, "{name}: {} of {}", c.motion_alarms, c.motion_states);
    }
    for rule in ["", "calibrated rule, "] {
        let goal = format!("plausibility checks, {rule}30 objects <= 5 us (steady traffic, objects-30/steady");
        let g = report.goals.iter().find(|g| g.goal.starts_with(&goal)).unwrap();
        assert!(g.measured.starts_with("objects-30/steady") && g.measured.contains("worst case"), "{g:?}");
    }
}

/// A case's medians of the frame statistics: points, points in the band, hit cells and clusters.
fn frame_statistics(c: &pmon_bench::CaseReport) -> (u32, u32, u32, u32) {
    (c.points, c.points_in_band, c.cells_hit, c.clusters)
}

#[test]
fn split_runs_the_same_frames_on_two_threads_and_says_so() {
    let only = vec!["synthetic-64/0.5m".to_string(), "synthetic-32".to_string()];
    let one = run_bench(&BenchOptions { only: only.clone(), ..quick() }).unwrap();
    let two = run_bench(&BenchOptions { only, split: true, ..quick() }).unwrap();
    assert_eq!(one.cases.len(), 2);
    for (a, b) in one.cases.iter().zip(&two.cases) {
        assert_eq!(a.name, b.name);
        // The medians of the frame statistics: the same points in band, hit cells and clusters.
        assert_eq!(frame_statistics(a), frame_statistics(b), "{}", a.name);
        // The 64-beam sweep is split; the 32-beam one (35,000 points) stays on one thread.
        let large = b.points as usize >= pmon_monitor::split::SPLIT_MIN_POINTS;
        assert_eq!(large, b.name.starts_with("synthetic-64"), "{}: {} points", b.name, b.points);
    }
    assert!(two.notes.iter().any(|n| n.starts_with("--split")), "{:?}", two.notes);
    assert!(!one.notes.iter().any(|n| n.starts_with("--split")), "{:?}", one.notes);
}

#[test]
fn columns_run_the_same_frames_and_say_so() {
    let only = vec!["synthetic-32/0.5m".to_string(), "objects-30/no-cloud".to_string()];
    let records = run_bench(&BenchOptions { only: only.clone(), ..quick() }).unwrap();
    let columns = run_bench(&BenchOptions { only, columns: true, ..quick() }).unwrap();
    // The 32-beam case and the object lists without a cloud (the paper's rule and the calibrated one).
    assert_eq!((records.cases.len(), columns.cases.len()), (3, 3));
    for (a, b) in records.cases.iter().zip(&columns.cases) {
        assert_eq!(a.name, b.name);
        assert_eq!(frame_statistics(a), frame_statistics(b), "{}", a.name);
    }
    assert!(columns.cases[0].points > 30_000, "the 32-beam sweep is measured: {}", columns.cases[0].points);
    assert!(columns.notes.iter().any(|n| n.starts_with("--columns")), "{:?}", columns.notes);
    assert!(!records.notes.iter().any(|n| n.starts_with("--columns")), "{:?}", records.notes);
}

/// A report says which params keys its options changed from the defaults: none by default (`--jump-from-returns`,
/// the default since issue #10, changes nothing), both jump keys with `--no-jump-from-returns`, and only the
/// first-return key with `--no-jump-first-return`.
#[test]
fn params_keys_changed_from_the_defaults_are_named_in_the_notes() {
    let only = vec!["objects-30/no-cloud".to_string()];
    let keys = |opts: BenchOptions| -> Option<String> {
        let report = run_bench(&BenchOptions { only: only.clone(), ..opts }).unwrap();
        report.notes.iter().find(|n| n.starts_with("params keys changed")).cloned()
    };
    let rules = |rules: RuleSwitches| BenchOptions { rules, ..quick() };
    assert_eq!(keys(quick()), None);
    assert_eq!(
        keys(rules(RuleSwitches { jump_from_returns: true, jump_first_return: true, ..RuleSwitches::default() })),
        None
    );
    let off = keys(rules(RuleSwitches { no_jump_from_returns: true, ..RuleSwitches::default() })).unwrap();
    assert!(off.ends_with("jump_from_returns = false, jump_first_return = false"), "{off}");
    let sums = keys(rules(RuleSwitches { no_jump_first_return: true, ..RuleSwitches::default() })).unwrap();
    assert!(sums.ends_with(": jump_first_return = false"), "{sums}");
    let over = keys(rules(RuleSwitches { seen_over: true, no_roi_graze: true, ..RuleSwitches::default() })).unwrap();
    assert!(over.ends_with(": seen_over = true, roi_graze_fraction = 0"), "{over}");
    // The two keys of issue #10's round "Two rules together" are on by default; `--front-cluster` is kept and changes
    // nothing, the `--no-` flags turn them off.
    assert_eq!(keys(rules(RuleSwitches { front_cluster: true, ..RuleSwitches::default() })), None);
    let two =
        keys(rules(RuleSwitches { no_front_cluster: true, no_memory_hold: true, ..RuleSwitches::default() })).unwrap();
    assert!(two.ends_with(": front_cluster = false, memory_hold_s = 0"), "{two}");
    // The pair of issue #10's round "Rays on the body with step 8 gated" is on by default too.
    assert_eq!(keys(rules(RuleSwitches { seen_body: true, follow_gate: true, ..RuleSwitches::default() })), None);
    let body =
        keys(rules(RuleSwitches { no_seen_body: true, no_follow_gate: true, ..RuleSwitches::default() })).unwrap();
    assert!(body.ends_with(": seen_body = false, follow_gate = false"), "{body}");
}

#[test]
fn each_frame_of_the_cycle_is_timed_alone_and_the_machine_beside_it() {
    // synthetic-32 cycles through 6 frames: 12 iterations check each twice; objects-30 has no cloud.
    let only = vec!["synthetic-32".into(), "objects-30/no-cloud".into()];
    let report = run_bench(&BenchOptions { iterations: 12, max_seconds_per_case: 100.0, only, ..quick() }).unwrap();
    let c = report.cases.iter().find(|c| c.name == "synthetic-32/0.5m").unwrap();
    assert_eq!(c.samples, 12);
    let frames: Vec<usize> = c.per_frame.iter().map(|f| f.frame).collect();
    assert_eq!(frames, [0, 1, 2, 3, 4, 5]);
    assert!(c.per_frame.iter().all(|f| f.samples == 2), "{:?}", c.per_frame);
    // Every frame's own figures lie within the case's: the samples are the case's, split by frame.
    for f in &c.per_frame {
        let t = f.sensor_checks;
        assert!(t.median_us > 0.0 && t.max_us <= c.sensor_checks.max_us, "{f:?}");
        assert!(f.clusters > 0, "{f:?}");
    }
    let heaviest = c.per_frame.iter().map(|f| f.sensor_checks.max_us).fold(0.0, f64::max);
    assert_eq!(heaviest, c.sensor_checks.max_us);
    let j = c.jitter_reference.expect("a case with a cloud has the machine's reference");
    assert!(j.median_us > 0.0 && j.p99_us >= j.median_us);
    let no_cloud = report.cases.iter().find(|c| c.name == "objects-30/no-cloud").unwrap();
    assert_eq!(no_cloud.jitter_reference, None);
    let table = report.to_table();
    assert!(table.contains("per frame of the cycle") && table.contains("machine"), "{table}");
    let goal = report.goals.iter().find(|g| g.goal == "synthetic-32/0.5m: sensor checks p99 <= 1.5x median").unwrap();
    assert!(goal.measured.contains("heaviest frame") && goal.measured.contains("on this machine"), "{goal:?}");
    let back: BenchReport = serde_json::from_str(&serde_json::to_string(&report).unwrap()).unwrap();
    assert_eq!(back.cases[0].per_frame.len(), report.cases[0].per_frame.len());
    // Without the machine's reference: none in the report, `-` in its column, the rest as before.
    let only = vec!["synthetic-32".into()];
    let opts =
        BenchOptions { iterations: 12, max_seconds_per_case: 100.0, only, no_machine_reference: true, ..quick() };
    let report = run_bench(&opts).unwrap();
    let c = report.cases.iter().find(|c| c.name == "synthetic-32/0.5m").unwrap();
    assert_eq!((c.samples, c.jitter_reference), (12, None));
    assert_eq!(c.per_frame.len(), 6);
    let goal = report.goals.iter().find(|g| g.goal == "synthetic-32/0.5m: sensor checks p99 <= 1.5x median").unwrap();
    assert!(goal.measured.contains("heaviest frame") && !goal.measured.contains("on this machine"), "{goal:?}");
}

/// The parameters a run starts from (`pmon bench --params`) reach every case, and the rule switches are named in
/// the notes as changes over them, not over the defaults.
#[test]
fn the_parameters_a_run_starts_from_reach_every_case() {
    let only = vec!["objects-30/no-cloud".to_string()];
    let over = |params: MonitorParams, rules: RuleSwitches| BenchOptions {
        only: only.clone(),
        params: Some((params, "a test's".to_string())),
        rules,
        ..quick()
    };
    // Room for 10 objects: the case's 30 are refused, so the case was checked with these parameters.
    let small = MonitorParams { max_objects: 10, ..MonitorParams::PAPER };
    let err = run_bench(&over(small, RuleSwitches::default())).unwrap_err();
    assert!(matches!(err, BenchError::Frame { .. }), "{err}");
    // A switch the parameters already hold changes nothing; another is named as a change over them.
    let seen = MonitorParams { seen_over: true, ..MonitorParams::PAPER };
    let report = run_bench(&over(seen, RuleSwitches { seen_over: true, ..RuleSwitches::default() })).unwrap();
    assert!(report
        .notes
        .iter()
        .any(|n| n == "parameters: a test's; each case keeps its own cell_size_m and grid_size_m"));
    assert!(!report.notes.iter().any(|n| n.starts_with("params keys changed")), "{:?}", report.notes);
    let report = run_bench(&over(seen, RuleSwitches { no_front_cluster: true, ..RuleSwitches::default() })).unwrap();
    assert!(
        report
            .notes
            .iter()
            .any(|n| n == "params keys changed over those parameters in every case: front_cluster = false"),
        "{:?}",
        report.notes
    );
}

/// Each whole check is also read on the thread's CPU clock (the worst case without the time slices the thread
/// lost): in the case, per frame, for the machine's fixed work, in the table and as a goal line; a check never runs
/// longer on its thread than it lasts on the wall clock (up to the clock reads around it). None of it with
/// `--no-cpu-time`, nor with `--split`, whose second thread this thread's clock does not see.
#[test]
#[cfg(target_os = "linux")]
fn the_checks_are_read_on_the_threads_cpu_clock_too() {
    let run = |no_cpu_time: bool, split: bool| {
        let only = vec!["synthetic-32".to_string(), "objects-30/no-cloud".to_string()];
        let opts = BenchOptions { iterations: 12, max_seconds_per_case: 100.0, only, no_cpu_time, split, ..quick() };
        run_bench(&opts).unwrap()
    };
    let goal_of = |r: &BenchReport| {
        r.goals
            .iter()
            .find(|g| g.goal.starts_with("synthetic-32/0.5m: whole check p99 <= 1.5x median in thread CPU"))
            .cloned()
    };
    let report = run(false, false);
    let c = report.cases.iter().find(|c| c.name == "synthetic-32/0.5m").unwrap();
    let cpu = c.check_cpu.expect("Linux has a thread CPU clock");
    assert!(cpu.median_us > 0.0 && cpu.p10_us <= cpu.median_us && cpu.p99_us <= cpu.max_us, "{cpu:?}");
    // The CPU time of a check is within its elapsed time: the wall clock's whole check plus the reads' cost.
    assert!(cpu.median_us <= c.total.median_us + 20.0, "cpu {cpu:?} against wall {:?}", c.total);
    assert!(c.per_frame.iter().all(|f| f.check_cpu.is_some()), "{:?}", c.per_frame);
    assert!(c.jitter_reference_cpu.is_some());
    // The object lists without a cloud are read too (the whole check is their plausibility checks).
    assert!(report.cases.iter().all(|c| c.check_cpu.is_some()));
    let goal = goal_of(&report).expect("a CPU-time worst-case line per sweep case");
    assert!(goal.measured.contains("in CPU time: p99"), "{goal:?}");
    let table = report.to_table();
    assert!(table.contains("mach cpu") && table.contains("thread's CPU time"), "{table}");
    let back: BenchReport = serde_json::from_str(&serde_json::to_string(&report).unwrap()).unwrap();
    assert_eq!(back.cases[0].check_cpu, report.cases[0].check_cpu);
    // Not read: nothing in the case, per frame, for the machine, or among the goals.
    for (no_cpu_time, split) in [(true, false), (false, true)] {
        let report = run(no_cpu_time, split);
        let c = report.cases.iter().find(|c| c.name == "synthetic-32/0.5m").unwrap();
        assert_eq!((c.check_cpu, c.jitter_reference_cpu), (None, None), "no_cpu_time {no_cpu_time}, split {split}");
        assert!(c.per_frame.iter().all(|f| f.check_cpu.is_none()));
        assert!(c.jitter_reference.is_some(), "the wall-clock reference stays");
        assert_eq!(goal_of(&report), None);
    }
}
