//! The sensor alarms behind a figure of `pmon reproduce`, by the test that raised them ([`Point::causes`]: a
//! ghost, or the position cause of a position error, docs/cli.md): `<figure>_causes.csv` (per point), a bar
//! chart and a table per figure in the report. A safety case can then say which test found the errors and which
//! raised the false alarms.
//!
//! [`Point::causes`]: pmon_campaign::experiments::Point::causes

use std::path::Path;

use anyhow::Result;
use pmon_campaign::experiments::Figure;
use pmon_campaign::{cause_name, CauseTally, Rate, CAUSES};
use pmon_report::{BarChart, BarGroup, TableCell};

/// Each curve of `fig` whose points carry causes, with its points' tallies summed.
fn by_curve(fig: &Figure) -> Vec<(&str, CauseTally)> {
    fig.curves
        .iter()
        .filter_map(|c| {
            let mut total: Option<CauseTally> = None;
            for t in c.points.iter().filter_map(|p| p.causes.as_ref()) {
                total.get_or_insert_with(CauseTally::default).add(t);
            }
            total.map(|t| (c.label.as_str(), t))
        })
        .collect()
}

/// The causes that raised at least one alarm on some curve of `curves`, in the order of their indices.
fn seen(curves: &[(&str, CauseTally)]) -> Vec<usize> {
    (0..CAUSES).filter(|&k| curves.iter().any(|(_, t)| t.found.get(k) + t.false_alarms.get(k) > 0)).collect()
}

fn count(t: &CauseTally, k: usize, found: bool) -> u64 {
    if found {
        t.found.get(k)
    } else {
        t.false_alarms.get(k)
    }
}

fn total(t: &CauseTally, found: bool) -> u64 {
    if found {
        t.found.total()
    } else {
        t.false_alarms.total()
    }
}

/// Writes `<figure>_causes.csv` (one row per curve, point and cause with an alarm: `curve,x,cause,found,
/// false_alarms`) and the bar chart `<figure>_causes.{svg,png}` (per curve, the share of its errors found and of
/// its false alarms that each test raised, side by side, with 95 % intervals). Returns whether the figure has
/// causes (nothing is written otherwise).
///
/// # Errors
/// Writing a file.
pub fn write(dir: &Path, fig: &Figure) -> Result<bool> {
    let curves = by_curve(fig);
    let causes = seen(&curves);
    if curves.is_empty() || causes.is_empty() {
        return Ok(false);
    }
    let id = &fig.spec.id;
    let mut rows = Vec::new();
    for c in fig.curves.iter() {
        for p in &c.points {
            let Some(t) = p.causes else { continue };
            for k in 0..CAUSES {
                let (found, false_alarms) = (count(&t, k, true), count(&t, k, false));
                if found + false_alarms > 0 {
                    rows.push([
                        c.label.clone(),
                        format!("{}", p.x),
                        cause_name(k).to_string(),
                        found.to_string(),
                        false_alarms.to_string(),
                    ]);
                }
            }
        }
    }
    pmon_report::write_csv(
        dir.join(format!("{id}_causes.csv")),
        &["curve", "x", "cause", "found", "false_alarms"],
        &rows,
    )?;
    let mut chart = BarChart::new(
        format!("{}: the test that raised each alarm", fig.spec.title),
        "test (position cause, or ghost)",
        "share of the curve's errors found / false alarms [%]",
        causes.iter().map(|&k| cause_name(k).to_string()).collect(),
    )
    .with_y_range(0.0, 100.0);
    // Per curve, the errors found and the false alarms side by side: a test whose share of the false alarms
    // exceeds its share of the errors found costs precision out of proportion.
    for (label, t) in &curves {
        for (found, what) in [(true, "errors found"), (false, "false alarms")] {
            let n = total(t, found);
            if n == 0 {
                continue;
            }
            let rates: Vec<Rate> = causes.iter().map(|&k| Rate::wilson(count(t, k, found), n)).collect();
            chart = chart.with_group(
                BarGroup::new(format!("{label}: {n} {what}"), rates.iter().map(|r| 100.0 * r.value).collect())
                    .with_errors(rates.iter().map(|r| (100.0 * r.lo, 100.0 * r.hi)).collect()),
            );
        }
    }
    chart.render_svg(dir.join(format!("{id}_causes.svg")))?;
    chart.render_png(dir.join(format!("{id}_causes.png")), 1600, 1000)?;
    Ok(true)
}

/// Adds a figure's alarms by cause to the report (the chart [`write()`] drew, a paragraph and the [`table`]), when
/// it has causes.
pub fn add_to_report(html: &mut pmon_report::HtmlReport, fig: &Figure) {
    let Some((headers, rows)) = table(fig) else { return };
    let id = &fig.spec.id;
    html.figure_with_data(
        &format!("{id}_causes.png"),
        &format!(
            "{}: which test raised the sensor alarms (a ghost, or the position cause of a position error; docs/cli.md), as a share of each curve's errors found and, beside it, of its false alarms, over all its points, with 95 % intervals: a test whose share of the false alarms exceeds its share of the errors found costs precision out of proportion",
            fig.spec.title
        ),
        &format!("{id}_causes.csv"),
    );
    html.paragraph("The same alarms counted: errors found are verifiable injected errors the sensor checks flagged; false alarms are alarms on clean object states of the same runs (the precision curve's). Summed over each curve's points; per point in the CSV.");
    html.table(&headers, &rows);
}

/// The report's table of a figure's alarms by cause: per curve and test, the errors found and the false alarms
/// (counts and shares of the curve's), summed over the curve's points. `None` when the figure has no causes.
#[must_use]
pub fn table(fig: &Figure) -> Option<(Vec<&'static str>, Vec<Vec<TableCell>>)> {
    let curves = by_curve(fig);
    let causes = seen(&curves);
    if causes.is_empty() {
        return None;
    }
    let share = |k: u64, n: u64| {
        if n == 0 {
            TableCell::num(k.to_string())
        } else {
            TableCell::num(format!("{k} ({:.1} %)", 100.0 * k as f64 / n as f64))
        }
    };
    let mut rows = Vec::new();
    for (label, t) in &curves {
        let (nf, na) = (total(t, true), total(t, false));
        for &k in &causes {
            let (f, a) = (count(t, k, true), count(t, k, false));
            if f + a == 0 {
                continue;
            }
            rows.push(vec![TableCell::new(*label), TableCell::new(cause_name(k)), share(f, nf), share(a, na)]);
        }
        rows.push(vec![
            TableCell::new(*label),
            TableCell::new("all tests"),
            TableCell::num(nf.to_string()),
            TableCell::num(na.to_string()),
        ]);
    }
    Some((vec!["curve", "test", "errors found (share)", "false alarms (share)"], rows))
}

#[cfg(test)]
mod tests {
    use super::*;
    use pmon_campaign::experiments::{Curve, FigureSpec, Point};

    fn figure(points: Vec<Point>) -> Figure {
        Figure {
            spec: FigureSpec {
                id: "f".into(),
                title: "F".into(),
                paper_ref: String::new(),
                x_label: "x".into(),
                y_label: "y".into(),
                refs: Vec::new(),
                y_range: (0.0, 1.0),
            },
            curves: vec![Curve { label: "c".into(), points, dashed: false }],
        }
    }

    /// The table sums a curve's points and lists only the tests that raised an alarm, with their shares; the
    /// files are written only for a figure with causes.
    #[test]
    fn alarms_by_test_are_summed_over_a_curve() {
        let mut a = CauseTally::default();
        a.found.displaced_evidence = 3;
        a.found.seen_through = 1;
        a.false_alarms.ghost = 2;
        let mut b = CauseTally::default();
        b.found.displaced_evidence = 4;
        let rate = Rate::wilson(0, 0);
        let fig = figure(vec![
            Point { causes: Some(a), ..Point::new(0.5, rate) },
            Point { causes: Some(b), ..Point::new(1.0, rate) },
            Point::new(1.5, rate),
        ]);
        let (_, rows) = table(&fig).unwrap();
        let text: Vec<Vec<String>> = rows.iter().map(|r| r.iter().map(|c| c.text.clone()).collect()).collect();
        assert_eq!(
            text,
            [
                ["c", "ghost", "0 (0.0 %)", "2 (100.0 %)"],
                ["c", "displaced_evidence", "7 (87.5 %)", "0 (0.0 %)"],
                ["c", "seen_through", "1 (12.5 %)", "0 (0.0 %)"],
                ["c", "all tests", "8", "2"],
            ]
        );
        let dir = tempfile::tempdir().unwrap();
        assert!(write(dir.path(), &fig).unwrap());
        let csv = std::fs::read_to_string(dir.path().join("f_causes.csv")).unwrap();
        assert_eq!(
            csv.lines().collect::<Vec<_>>(),
            [
                "curve,x,cause,found,false_alarms",
                "c,0.5,ghost,0,2",
                "c,0.5,displaced_evidence,3,0",
                "c,0.5,seen_through,1,0",
                "c,1,displaced_evidence,4,0",
            ]
        );
        assert!(dir.path().join("f_causes.png").exists());
        let none = figure(vec![Point::new(1.0, rate)]);
        assert!(table(&none).is_none());
        assert!(!write(dir.path(), &none).unwrap());
    }
}
