//! The HTML report and the CSV helper.

use pmon_report::{escape_html, write_csv, CellClass, HtmlReport, ReportError, TableCell};

#[test]
fn escape_covers_the_special_characters() {
    assert_eq!(escape_html(r#"<a href="x">&'</a>"#), "&lt;a href=&quot;x&quot;&gt;&amp;&#39;&lt;/a&gt;");
    assert_eq!(escape_html("σ = 0.7 m"), "σ = 0.7 m");
}

#[test]
fn report_escapes_all_text_and_keeps_structure() {
    let mut r = HtmlReport::new("Run <1> & \"2\"");
    r.heading("H <h>")
        .subheading("sub & sub")
        .paragraph("<script>alert(1)</script>")
        .table(
            &["a<", "b&"],
            &[
                vec![TableCell::pass("ok <yes>"), TableCell::miss("no & never")],
                vec![TableCell::with_class("1.5", CellClass::Num)],
                vec!["plain \"q\"".into()],
            ],
        )
        .figure("fig \"1\".svg", "Caption <i>")
        .figure_with_data("f2.png", "C2", "f2 & data.csv")
        .preformatted("line 1\n<tag> & more");
    let html = r.to_html();

    assert!(html.starts_with("<!DOCTYPE html>"));
    assert!(html.contains("<title>Run &lt;1&gt; &amp; &quot;2&quot;</title>"));
    assert!(html.contains("<h1>Run &lt;1&gt; &amp; &quot;2&quot;</h1>"));
    assert!(html.contains("<h2>H &lt;h&gt;</h2>"));
    assert!(html.contains("<h3>sub &amp; sub</h3>"));
    assert!(html.contains("<p>&lt;script&gt;alert(1)&lt;/script&gt;</p>"));
    assert!(!html.contains("<script>"));
    assert!(html.contains("<th>a&lt;</th><th>b&amp;</th>"));
    assert!(html.contains("<td class=\"pass\">ok &lt;yes&gt;</td><td class=\"miss\">no &amp; never</td>"));
    // Short rows are padded to the header width.
    assert!(html.contains("<td class=\"num\">1.5</td><td></td></tr>"));
    assert!(html.contains("<td>plain &quot;q&quot;</td><td></td>"));
    assert!(html.contains("<img src=\"fig &quot;1&quot;.svg\" alt=\"Caption &lt;i&gt;\">"));
    assert!(html.contains("<a href=\"f2 &amp; data.csv\">[data]</a>"));
    assert!(html.contains("<pre>line 1\n&lt;tag&gt; &amp; more</pre>"));
    // Self-contained: inline CSS, no external resources.
    assert!(html.contains("<style>") && html.contains("td.pass"));
    assert!(!html.contains("http://") && !html.contains("https://") && !html.contains("<link"));
}

#[test]
fn report_writes_a_file_and_names_it_on_error() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path().join("index.html");
    let mut r = HtmlReport::new("t");
    r.paragraph("hello");
    r.write(&p).expect("write");
    assert_eq!(std::fs::read_to_string(&p).expect("read"), r.to_html());

    let err = r.write("/nonexistent-pmon-dir/index.html").expect_err("no folder");
    assert!(matches!(err, ReportError::Io { .. }));
    assert!(err.to_string().contains("/nonexistent-pmon-dir/index.html"), "{err}");
}

#[test]
fn csv_quotes_what_needs_quoting() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path().join("data.csv");
    write_csv(&p, &["name", "value"], &[vec!["plain", "1.5"], vec!["a,b", "say \"hi\""], vec!["two\nlines", ""]])
        .expect("csv");
    let text = std::fs::read_to_string(&p).expect("read");
    assert_eq!(text, "name,value\nplain,1.5\n\"a,b\",\"say \"\"hi\"\"\"\n\"two\nlines\",\n");
}

#[test]
fn csv_rejects_ragged_rows_naming_the_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path().join("ragged.csv");
    let err = write_csv(&p, &["a", "b"], &[vec!["1", "2"], vec!["3"]]).expect_err("ragged");
    assert!(matches!(err, ReportError::Csv { .. }), "{err:?}");
    assert!(err.to_string().contains("ragged.csv"), "{err}");
}
