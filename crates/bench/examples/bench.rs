//! Runs the latency benchmarks and prints the table (or JSON), like `pmon bench`:
//! `cargo run --release -p pmon-bench --example bench -- [--json] [--iterations N] [--max-seconds-per-case S]
//! [--only TEXT]... [--columns] [--kitti-whole-grid] [--no-machine-reference] [--no-cpu-time]` (`--only`: the cases whose name
//! contains one of the texts, as `pmon bench --only`; `--columns`: the sweeps handed over as columns, as `pmon bench
//! --columns`; the last three as `pmon bench`'s flags of the same names).

use std::process::ExitCode;

use pmon_bench::{run_bench, BenchOptions};

fn main() -> ExitCode {
    let mut opts = BenchOptions::default();
    let mut json = false;
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--json" => json = true,
            "--columns" => opts.columns = true,
            "--kitti-whole-grid" => opts.kitti_whole_grid = true,
            "--no-machine-reference" => opts.no_machine_reference = true,
            "--no-cpu-time" => opts.no_cpu_time = true,
            "--iterations" => match args.next().and_then(|v| v.parse().ok()) {
                Some(n) => opts.iterations = n,
                None => {
                    eprintln!("--iterations needs a whole number");
                    return ExitCode::from(2);
                }
            },
            "--max-seconds-per-case" => match args.next().and_then(|v| v.parse().ok()) {
                Some(s) => opts.max_seconds_per_case = s,
                None => {
                    eprintln!("--max-seconds-per-case needs a number");
                    return ExitCode::from(2);
                }
            },
            "--only" => match args.next() {
                Some(text) => opts.only.push(text),
                None => {
                    eprintln!("--only needs a text");
                    return ExitCode::from(2);
                }
            },
            other => {
                eprintln!(
                    "unknown argument `{other}`; usage: bench [--json] [--iterations N] [--max-seconds-per-case S] \
                     [--only TEXT]... [--columns] [--kitti-whole-grid] [--no-machine-reference]"
                );
                return ExitCode::from(2);
            }
        }
    }
    match run_bench(&opts) {
        Ok(report) if json => match serde_json::to_string_pretty(&report) {
            Ok(text) => {
                println!("{text}");
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: cannot serialise the report: {e}");
                ExitCode::FAILURE
            }
        },
        Ok(report) => {
            print!("{}", report.to_table());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
