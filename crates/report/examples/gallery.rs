//! Renders one of each figure (SVG, PNG and CSV) plus an HTML page linking them into a folder.
//!
//! ```text
//! cargo run -p pmon-report --example gallery -- /tmp/pmon-gallery
//! ```
//! The data is synthetic (smooth curves shaped like the paper's), not a measurement.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use pmon_report::{
    BarChart, BarGroup, BoxKind, CellState, HtmlReport, LegendPosition, LineChart, RefLine, ReportError, Series,
    SeriesColor, TableCell, TopView, ViewBox, ViewCell, ViewCluster,
};

/// A logistic detection-rate curve with a binomial-like 95 % band for `n` trials per point.
fn detection_curve(name: &str, x50: f64, slope: f64, n: f64) -> Series {
    let mut pts = Vec::new();
    let mut band = Vec::new();
    for i in 0..=20 {
        let x = f64::from(i) * 0.1;
        let p = 1.0 / (1.0 + (-(x - x50) / slope).exp());
        let half = 1.96 * (p * (1.0 - p) / n).sqrt() + 0.01;
        pts.push((x, p));
        band.push((x, (p - half).max(0.0), (p + half).min(1.0)));
    }
    Series::new(name, pts).with_band(band)
}

fn detection_chart() -> LineChart {
    LineChart::new("Permanent position error", "position error [m]", "detection rate")
        .with_y_range(0.0, 1.0)
        .with_x_range(0.0, 2.0)
        .with_series(detection_curve("sensor check, 0.2 m cells", 0.45, 0.08, 150.0).with_markers())
        .with_series(detection_curve("sensor check, 0.5 m cells", 0.75, 0.10, 150.0).with_markers())
        .with_series(detection_curve("plausibility check", 1.05, 0.15, 150.0).dashed())
        .with_ref_line(RefLine::vertical(0.7, "paper: 0.7 m"))
        .with_ref_line(RefLine::horizontal(0.9, "90 %"))
}

fn false_alarm_chart() -> LineChart {
    let sensor: Vec<(f64, f64)> =
        (0..=10).map(|i| f64::from(i) * 0.05).map(|s| (s, 0.002 + 0.4 * (s / 0.5).powi(4))).collect();
    let band: Vec<(f64, f64, f64)> = sensor.iter().map(|&(s, r)| (s, r * 0.7, r * 1.3 + 0.002)).collect();
    let plaus: Vec<(f64, f64)> = (0..=10).map(|i| f64::from(i) * 0.05).map(|s| (s, 0.01 + 0.05 * s)).collect();
    LineChart::new("False alarms", "position uncertainty σ [m]", "false alarm rate")
        .with_y_range(0.0, 0.5)
        .with_series(Series::new("sensor checks", sensor).with_band(band).with_markers())
        .with_series(Series::new("plausibility checks", plaus).with_markers().dashed())
        .with_ref_line(RefLine::horizontal(0.05, "5 % budget").with_color(SeriesColor::Rgb(200, 0, 0)))
}

fn latency_chart() -> BarChart {
    let cats = ["rasterize", "sensor check", "plausibility", "clusters", "total"].map(String::from).to_vec();
    BarChart::new("Monitor latency per frame", "component", "latency [ms]", cats)
        .with_group(BarGroup::new("0.5 m cells", vec![0.8, 1.1, 0.05, 0.2, 2.2]).with_errors(vec![
            (0.7, 1.0),
            (0.9, 1.5),
            (0.04, 0.07),
            (0.15, 0.3),
            (1.9, 2.8),
        ]))
        .with_group(BarGroup::new("0.2 m cells", vec![1.9, 3.4, 0.05, 0.6, 6.0]).with_errors(vec![
            (1.6, 2.3),
            (2.9, 4.4),
            (0.04, 0.07),
            (0.4, 0.9),
            (5.1, 7.4),
        ]))
        .with_ref_line(RefLine::horizontal(5.0, "budget 5 ms"))
        .with_legend(LegendPosition::Auto)
}

fn top_view() -> TopView {
    let cell = 0.5f32;
    let mut v = TopView::new("Frame 42: injected position error", (-10.0, -15.0, 40.0, 15.0), cell);
    // Unknown beyond 35 m, free elsewhere, occupied under objects, a conflict blob where the truth is.
    for ix in -20..80 {
        for iy in -30..30 {
            let (x, y) = ((ix as f32 + 0.5) * cell, (iy as f32 + 0.5) * cell);
            let in_box = |cx: f32, cy: f32, hl: f32, hw: f32| (x - cx).abs() < hl && (y - cy).abs() < hw;
            let state = if x > 35.0 || (x > 20.0 && y > 8.0) {
                CellState::Unknown
            } else if in_box(12.0, 3.5, 2.2, 1.0) || in_box(25.0, -4.0, 0.4, 0.4) {
                CellState::Occupied
            } else if in_box(17.0, -2.0, 2.2, 1.0) {
                CellState::Conflict
            } else {
                CellState::Free
            };
            v.cells.push(ViewCell { x_m: x, y_m: y, state });
        }
    }
    // Points on the visible edges of the objects.
    for k in 0..40 {
        let t = k as f32 / 39.0;
        v.points.push([9.8, 2.5 + 2.0 * t]);
        v.points.push([9.8 + 4.4 * t, 2.5]);
        v.points.push([14.8, -3.0 + 2.0 * t]);
        v.points.push([14.8 + 4.4 * t, -3.0]);
        v.points.push([24.6 + 0.8 * t, -4.4]);
    }
    let car = |x: f32, y: f32, h: f32, label: &str, kind: BoxKind, grow: f32| ViewBox {
        x_m: x,
        y_m: y,
        heading_rad: h,
        length_m: 4.4,
        width_m: 1.9,
        grown_length_m: 4.4 + grow,
        grown_width_m: 1.9 + grow,
        label: label.into(),
        kind,
    };
    v.boxes.push(car(12.0, 3.5, 0.0, "#3 car", BoxKind::Consistent, 0.8));
    v.boxes.push(car(17.0, -2.0, 0.0, "#7 truth", BoxKind::InjectedTruth, 0.0));
    v.boxes.push(car(18.5, -6.5, 0.35, "#7 car (+1.5 m, -4.5 m)", BoxKind::PositionError, 0.8));
    v.boxes.push(ViewBox {
        x_m: 25.0,
        y_m: -4.0,
        heading_rad: 1.2,
        length_m: 0.8,
        width_m: 0.8,
        grown_length_m: 1.6,
        grown_width_m: 1.6,
        label: "#9 ped".into(),
        kind: BoxKind::Implausible,
    });
    v.boxes.push(car(5.0, -8.0, -0.2, "#11 ghost", BoxKind::Ghost, 0.8));
    v.boxes.push(car(37.0, 10.0, 3.1, "#12", BoxKind::NotMonitored, 0.0));
    v.clusters.push(ViewCluster { bounds_m: [14.75, -3.0, 19.25, -1.0], label: "cluster 1 (36 cells)".into() });
    v.arrows.push(([17.0, -2.0], [18.5, -6.5]));
    v
}

fn render_all(dir: &Path) -> Result<(), ReportError> {
    let mut report = HtmlReport::new("pmon report gallery");
    report.paragraph("One of each figure kind, rendered from synthetic data by the pmon-report gallery example.");

    let line_figs: [(&str, &str, LineChart); 2] = [
        ("detection", "Detection rate over a permanent position error, with 95 % bands.", detection_chart()),
        ("false_alarm", "False alarm rate for different position uncertainties.", false_alarm_chart()),
    ];
    for (name, caption, chart) in &line_figs {
        chart.render_svg(dir.join(format!("{name}.svg")))?;
        chart.render_png(dir.join(format!("{name}.png")), 1200, 750)?;
        chart.write_csv(dir.join(format!("{name}.csv")))?;
        report.heading(&chart.title).figure_with_data(&format!("{name}.svg"), caption, &format!("{name}.csv"));
    }

    let bars = latency_chart();
    bars.render_svg(dir.join("latency.svg"))?;
    bars.render_png(dir.join("latency.png"), 1200, 750)?;
    bars.write_csv(dir.join("latency.csv"))?;
    report.heading("Latency").figure_with_data(
        "latency.svg",
        "Latency per component (5th-95th percentile).",
        "latency.csv",
    );

    let view = top_view();
    view.render_svg(dir.join("topview.svg"))?;
    view.render_png(dir.join("topview.png"), 1400, 900)?;
    report.heading("Top view").figure("topview.png", "One frame with an injected position error of object #7.");

    report.heading("Expectations").table(
        &["experiment", "measured", "paper", "verdict"],
        &[
            vec![
                "dx_min, 0.2 m cells".into(),
                TableCell::num("0.52 m"),
                TableCell::num("0.5 m"),
                TableCell::pass("pass"),
            ],
            vec![
                "dx_min, 0.5 m cells".into(),
                TableCell::num("0.93 m"),
                TableCell::num("0.7 m"),
                TableCell::miss("miss"),
            ],
            vec![
                "false alarms <script>".into(),
                TableCell::num("0.4 %"),
                TableCell::num("< 1 %"),
                TableCell::pass("pass"),
            ],
        ],
    );
    report.preformatted("pmon campaign --seed 7 --frames 2000\n  cell_size_m = 0.2 & 0.5 <ok>");
    report.write(dir.join("index.html"))
}

fn main() -> ExitCode {
    let dir = std::env::args_os().nth(1).map(PathBuf::from).unwrap_or_else(|| PathBuf::from("gallery"));
    if let Err(e) = std::fs::create_dir_all(&dir) {
        eprintln!("cannot create {}: {e}", dir.display());
        return ExitCode::FAILURE;
    }
    match render_all(&dir) {
        Ok(()) => {
            println!("wrote the gallery to {}", dir.join("index.html").display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
