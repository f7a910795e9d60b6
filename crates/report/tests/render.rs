//! Rendering every figure kind to files: valid output, robustness to bad data, the embedded font, errors.

use std::path::Path;

use pmon_report::{
    BarChart, BarGroup, BoxKind, CellState, Figure, LegendPosition, LineChart, RefLine, ReportError, Series, TopView,
    ViewBox, ViewCell, ViewCluster,
};

const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A];

/// Decodes a PNG into (width, height, RGB or RGBA bytes, channels).
fn decode(bytes: &[u8]) -> (u32, u32, Vec<u8>, usize) {
    assert!(bytes.starts_with(&PNG_SIGNATURE), "not a PNG");
    let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut reader = decoder.read_info().expect("PNG header");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("PNG data");
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf, info.color_type.samples())
}

/// Number of pixels darker than `max_luma` in rows `rows` of a decoded image.
fn dark_pixels(img: &(u32, u32, Vec<u8>, usize), rows: std::ops::Range<u32>, max_luma: u32) -> usize {
    let (w, _, data, ch) = img;
    rows.flat_map(|y| (0..*w).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            let i = ((y * w + x) as usize) * ch;
            let luma = (u32::from(data[i]) * 3 + u32::from(data[i + 1]) * 6 + u32::from(data[i + 2])) / 10;
            luma <= max_luma
        })
        .count()
}

fn detection_chart() -> LineChart {
    let pts: Vec<(f64, f64)> =
        (0..=20).map(|i| f64::from(i) * 0.1).map(|x| (x, 1.0 / (1.0 + (-(x - 0.7) * 10.0).exp()))).collect();
    let band = pts.iter().map(|&(x, y)| (x, (y - 0.05).max(0.0), (y + 0.05).min(1.0))).collect();
    LineChart::new("Detection of position errors", "position error [m]", "detection rate")
        .with_y_range(0.0, 1.0)
        .with_series(Series::new("sensor check", pts.clone()).with_band(band).with_markers())
        .with_series(Series::new("plausibility", pts.iter().map(|&(x, y)| (x, y * 0.8)).collect()).dashed())
        .with_ref_line(RefLine::vertical(0.7, "paper: 0.7 m"))
        .with_ref_line(RefLine::horizontal(0.9, "90 %"))
}

fn latency_chart() -> BarChart {
    BarChart::new("Latency", "component", "latency [ms]", vec!["grid".into(), "check".into(), "total".into()])
        .with_group(BarGroup::new("0.5 m", vec![1.0, 2.0, 3.0]).with_errors(vec![(0.8, 1.2), (1.5, 2.5), (2.5, 3.6)]))
        .with_group(BarGroup::new("0.2 m", vec![2.0, 4.0, 6.0]))
        .with_ref_line(RefLine::horizontal(5.0, "budget"))
}

fn top_view() -> TopView {
    let mut v = TopView::new("Top view frame 7", (-10.0, -10.0, 30.0, 10.0), 0.5);
    for ix in 0..40 {
        for iy in -10i32..10 {
            let state = match (ix + iy).rem_euclid(4) {
                0 => CellState::Occupied,
                1 => CellState::Conflict,
                2 => CellState::Free,
                _ => CellState::Unknown,
            };
            v.cells.push(ViewCell { x_m: ix as f32 * 0.5 + 0.25, y_m: iy as f32 * 0.5 + 0.25, state });
        }
    }
    v.points = (0..500).map(|i| [i as f32 * 0.05, (i as f32 * 0.1).sin() * 5.0]).collect();
    v.boxes.push(ViewBox {
        x_m: 10.0,
        y_m: 2.0,
        heading_rad: 0.4,
        length_m: 4.5,
        width_m: 1.8,
        grown_length_m: 5.5,
        grown_width_m: 2.8,
        label: "#1 car".into(),
        kind: BoxKind::PositionError,
    });
    v.boxes.push(ViewBox {
        x_m: 8.0,
        y_m: -1.0,
        heading_rad: 0.0,
        length_m: 4.5,
        width_m: 1.8,
        grown_length_m: 4.5,
        grown_width_m: 1.8,
        label: "#1 truth".into(),
        kind: BoxKind::InjectedTruth,
    });
    v.clusters.push(ViewCluster { bounds_m: [6.0, -2.0, 10.0, 0.0], label: "cluster 0".into() });
    v.arrows.push(([8.0, -1.0], [10.0, 2.0]));
    v
}

fn figures() -> Vec<(&'static str, Box<dyn Figure>, [&'static str; 3])> {
    vec![
        ("line", Box::new(detection_chart()), ["Detection of position errors", "position error [m]", "detection rate"]),
        ("bar", Box::new(latency_chart()), ["Latency", "component", "latency [ms]"]),
        ("top", Box::new(top_view()), ["Top view frame 7", "x (forward) [m]", "y (left) [m]"]),
    ]
}

#[test]
fn every_figure_renders_valid_svg_and_png_files() {
    let dir = tempfile::tempdir().expect("tempdir");
    for (name, fig, texts) in figures() {
        let svg_path = dir.path().join(format!("{name}.svg"));
        fig.render_svg(&svg_path).expect("svg");
        let svg = std::fs::read_to_string(&svg_path).expect("read svg");
        assert!(svg.starts_with("<svg"), "{name}: not an SVG");
        assert!(svg.trim_end().ends_with("</svg>"), "{name}: SVG not closed");
        for t in texts {
            assert!(
                svg.contains(&format!(">{t}<")) || svg.contains(&format!(">\n{t}\n<")),
                "{name}: SVG lacks text {t:?}"
            );
        }

        let png_path = dir.path().join(format!("{name}.png"));
        fig.render_png(&png_path, 640, 420).expect("png");
        let bytes = std::fs::read(&png_path).expect("read png");
        let img = decode(&bytes);
        assert_eq!((img.0, img.1), (640, 420), "{name}: wrong PNG size");
        // A white figure with something drawn on it.
        let dark = dark_pixels(&img, 0..420, 100);
        assert!(dark > 2_000, "{name}: only {dark} dark pixels");
        let (w, h, data, ch) = &img;
        let corner = &data[..*ch];
        assert_eq!(&corner[..3], &[255, 255, 255], "{name}: background not white");
        assert!(data.len() == (*w as usize) * (*h as usize) * ch);
    }
}

#[test]
fn svg_text_is_escaped() {
    let chart =
        LineChart::new("a <b> & \"c\"", "x", "y").with_series(Series::new("s<1>", vec![(0.0, 0.0), (1.0, 1.0)]));
    let svg = chart.render_svg_string().expect("svg");
    assert!(svg.contains("a &lt;b&gt; &amp; &quot;c&quot;"), "title not escaped");
    assert!(svg.contains("s&lt;1&gt;"), "legend not escaped");
    assert!(!svg.contains("<b>"));
}

#[test]
fn the_embedded_font_draws_text_without_system_fonts() {
    // Two charts with the same layout (a title line of the same height) whose titles differ only in ink: the dark
    // pixels in the title band must come from the glyphs of the embedded font.
    let wide = LineChart::new("MMMMMMMM WWWWWWWW", "", "").with_legend(LegendPosition::Hidden);
    let thin = LineChart::new("i", "", "").with_legend(LegendPosition::Hidden);
    let wide = decode(&wide.render_png_bytes(800, 500).expect("png"));
    let thin = decode(&thin.render_png_bytes(800, 500).expect("png"));
    let title_rows = 0..30;
    let dark_wide = dark_pixels(&wide, title_rows.clone(), 128);
    let dark_thin = dark_pixels(&thin, title_rows, 128);
    assert!(dark_thin > 0 && dark_thin < 60, "a single 'i' should be a few dark pixels, got {dark_thin}");
    assert!(dark_wide > 10 * dark_thin.max(30), "title glyphs missing: {dark_wide} dark pixels");
    // Below the title band the two images are identical (same layout).
    let row_bytes = 800 * wide.3;
    assert_eq!(wide.2[40 * row_bytes..], thin.2[40 * row_bytes..]);
}

#[test]
fn degenerate_data_never_panics() {
    let nan = f64::NAN;
    let inf = f64::INFINITY;
    let lines = vec![
        LineChart::default(),
        LineChart::new("empty series", "x", "y").with_series(Series::new("none", vec![])),
        LineChart::new("all NaN", "x", "y").with_series(Series::new("nan", vec![(nan, nan), (nan, 1.0), (1.0, nan)])),
        LineChart::new("one point", "x", "y").with_series(Series::new("one", vec![(0.5, 0.5)])),
        LineChart::new("one point band", "x", "y")
            .with_series(Series::new("one", vec![(0.5, 0.5)]).with_band(vec![(0.5, 0.4, 0.6)])),
        LineChart::new("gaps", "x", "y").with_series(
            Series::new("gappy", vec![(0.0, 0.0), (1.0, nan), (2.0, 2.0), (3.0, inf), (4.0, 1.0), (5.0, 2.0)])
                .with_band(vec![(0.0, 0.0, 1.0), (nan, 0.0, 1.0), (2.0, 3.0, 1.0), (4.0, inf, 1.0), (5.0, 1.0, 3.0)])
                .with_markers(),
        ),
        LineChart::new("bad ranges", "x", "y")
            .with_x_range(nan, 1.0)
            .with_y_range(1.0, 1.0)
            .with_series(Series::new("s", vec![(0.0, 0.0), (1.0, 1.0)])),
        LineChart::new("outside range", "x", "y")
            .with_x_range(0.0, 1.0)
            .with_y_range(0.0, 1.0)
            .with_series(Series::new("far", vec![(-1e300, -1e300), (1e300, 1e300), (5.0, 5.0)]).with_markers())
            .with_ref_line(RefLine::horizontal(7.0, "off-plot"))
            .with_ref_line(RefLine::vertical(nan, "nan")),
        LineChart::new("huge", "x", "y").with_series(Series::new("big", vec![(0.0, -1e300), (1.0, 1e300)])),
        LineChart::new("tiny", "x", "y").with_series(Series::new("small", vec![(0.0, 1e-300), (1e-300, 2e-300)])),
        LineChart::new("flat", "x", "y")
            .with_legend(LegendPosition::OutsideRight)
            .with_series(Series::new("flat", vec![(1.0, 1.0), (1.0, 1.0)]).scatter()),
    ];
    for chart in &lines {
        chart.render_svg_string().unwrap_or_else(|e| panic!("{}: {e}", chart.title));
        chart.render_png_bytes(320, 200).unwrap_or_else(|e| panic!("{}: {e}", chart.title));
    }

    let bars = vec![
        BarChart::default(),
        BarChart::new("no groups", "c", "v", vec!["a".into()]),
        BarChart::new("short values", "c", "v", vec!["a".into(), "b".into(), "c".into()])
            .with_group(BarGroup::new("g", vec![1.0]).with_errors(vec![(nan, 2.0)])),
        BarChart::new("nan values", "c", "v", vec!["a".into(), "b".into()])
            .with_group(BarGroup::new("g", vec![nan, -inf]))
            .with_y_range(inf, 0.0),
        BarChart::new("negative", "c", "v", vec!["a".into(), "b".into()])
            .with_group(BarGroup::new("g", vec![-1.0, 2.0]).with_errors(vec![(-1.5, -0.5), (3.0, 1.0)]))
            .with_y_range(0.5, 1.5),
    ];
    for chart in &bars {
        chart.render_svg_string().unwrap_or_else(|e| panic!("{}: {e}", chart.title));
        chart.render_png_bytes(320, 200).unwrap_or_else(|e| panic!("{}: {e}", chart.title));
    }

    let nf = f32::NAN;
    let mut bad = TopView::new("bad", (nf, 0.0, 0.0, f32::INFINITY), nf);
    bad.cells.push(ViewCell { x_m: nf, y_m: 0.0, state: CellState::Occupied });
    bad.points.push([nf, 1.0]);
    bad.boxes.push(ViewBox {
        x_m: 1.0,
        y_m: 1.0,
        heading_rad: nf,
        length_m: 1.0,
        width_m: 1.0,
        grown_length_m: nf,
        grown_width_m: 2.0,
        label: "nan heading".into(),
        kind: BoxKind::Ghost,
    });
    bad.clusters.push(ViewCluster { bounds_m: [nf, 0.0, 1.0, 1.0], label: "nan".into() });
    bad.arrows.push(([0.0, 0.0], [nf, 1.0]));
    let mut far = TopView::new("far away", (0.0, 0.0, 10.0, 10.0), 0.2);
    far.boxes.push(ViewBox {
        x_m: 1e30,
        y_m: -1e30,
        heading_rad: 1.0,
        length_m: 1e30,
        width_m: 1.0,
        grown_length_m: 2e30,
        grown_width_m: 2.0,
        label: "far".into(),
        kind: BoxKind::Consistent,
    });
    far.cells.push(ViewCell { x_m: 1e30, y_m: 0.0, state: CellState::Free });
    far.arrows.push(([-1e30, 5.0], [1e30, 5.0]));
    for view in [TopView::default(), TopView::new("zero extent", (0.0, 0.0, 0.0, 0.0), 0.0), bad, far] {
        view.render_svg_string().unwrap_or_else(|e| panic!("{}: {e}", view.title));
        view.render_png_bytes(300, 300).unwrap_or_else(|e| panic!("{}: {e}", view.title));
    }
}

#[test]
fn rendering_is_deterministic() {
    for (name, fig, _) in figures() {
        assert_eq!(fig.render_svg_string().expect("svg"), fig.render_svg_string().expect("svg"), "{name}");
        assert_eq!(
            fig.render_png_bytes(300, 200).expect("png"),
            fig.render_png_bytes(300, 200).expect("png"),
            "{name}"
        );
    }
}

#[test]
fn errors_name_the_file() {
    let chart = detection_chart();
    let missing = Path::new("/nonexistent-pmon-dir/sub/fig.png");
    let err = chart.render_png(missing, 100, 100).expect_err("folder does not exist");
    assert!(matches!(err, ReportError::Io { .. }), "{err:?}");
    assert!(err.to_string().contains("/nonexistent-pmon-dir/sub/fig.png"), "{err}");
    let err = chart.render_svg(Path::new("/nonexistent-pmon-dir/fig.svg")).expect_err("folder does not exist");
    assert!(err.to_string().contains("/nonexistent-pmon-dir/fig.svg"), "{err}");

    let err = chart.render_png(Path::new("x.png"), 0, 100).expect_err("zero width");
    assert!(matches!(err, ReportError::InvalidSize { width_px: 0, .. }), "{err:?}");
    assert!(err.to_string().contains("x.png"), "{err}");
    assert!(chart.render_png_bytes(100, pmon_report::MAX_PNG_SIDE_PX + 1).is_err());
}

#[test]
fn top_view_svg_thins_dense_point_clouds() {
    let mut v = TopView::new("dense", (0.0, 0.0, 10.0, 10.0), 0.5);
    v.points = (0..100_000).map(|i| [(i % 1000) as f32 * 0.01, (i / 1000) as f32 * 0.1]).collect();
    let svg = v.render_svg_string().expect("svg");
    let rects = svg.matches("<rect").count();
    assert!(rects <= TopView::MAX_SVG_POINTS + 200, "{rects} rects");
    assert!(rects >= TopView::MAX_SVG_POINTS / 2, "{rects} rects: points lost");
}

#[test]
fn charts_write_their_data_as_csv() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path().join("line.csv");
    detection_chart().write_csv(&p).expect("csv");
    let text = std::fs::read_to_string(&p).expect("read");
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("series,x,y,lo,hi"));
    assert_eq!(lines.next(), Some("sensor check,0,0.0009110511944006454,,"));
    // 21 + 21 points, 21 band rows.
    assert_eq!(text.lines().count(), 1 + 21 + 21 + 21);

    let p = dir.path().join("bar.csv");
    latency_chart().write_csv(&p).expect("csv");
    let text = std::fs::read_to_string(&p).expect("read");
    assert_eq!(text.lines().next(), Some("category,group,value,err_lo,err_hi"));
    assert!(text.contains("grid,0.5 m,1,0.8,1.2\n"), "{text}");
    assert!(text.contains("grid,0.2 m,2,,\n"), "{text}");
}
