//! A static, self-contained HTML report: headings, text, tables with coloured verdict cells, figures.

use std::fmt::Write as _;
use std::path::Path;

use crate::render::write_file;
use crate::ReportError;

/// Escapes text for HTML element content and double- or single-quoted attribute values.
pub fn escape_html(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// How a table cell is highlighted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CellClass {
    /// Green: a check that passed, an expectation met.
    Pass,
    /// Red: a miss, a failed expectation.
    Miss,
    /// Yellow: borderline or worth a look.
    Warn,
    /// Grey text: not applicable, skipped.
    Muted,
    /// Right-aligned with tabular digits.
    Num,
}

impl CellClass {
    fn css(self) -> &'static str {
        match self {
            Self::Pass => "pass",
            Self::Miss => "miss",
            Self::Warn => "warn",
            Self::Muted => "muted",
            Self::Num => "num",
        }
    }
}

/// One table cell: text (escaped when written) and an optional highlight.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct TableCell {
    /// The cell text.
    pub text: String,
    /// The highlight, if any.
    pub class: Option<CellClass>,
}

impl TableCell {
    /// A plain cell.
    pub fn new(text: impl Into<String>) -> Self {
        Self { text: text.into(), class: None }
    }
    /// A highlighted cell.
    pub fn with_class(text: impl Into<String>, class: CellClass) -> Self {
        Self { text: text.into(), class: Some(class) }
    }
    /// A green cell.
    pub fn pass(text: impl Into<String>) -> Self {
        Self::with_class(text, CellClass::Pass)
    }
    /// A red cell.
    pub fn miss(text: impl Into<String>) -> Self {
        Self::with_class(text, CellClass::Miss)
    }
    /// A right-aligned number cell.
    pub fn num(text: impl Into<String>) -> Self {
        Self::with_class(text, CellClass::Num)
    }
}

impl From<&str> for TableCell {
    fn from(s: &str) -> Self {
        Self::new(s)
    }
}

impl From<String> for TableCell {
    fn from(s: String) -> Self {
        Self::new(s)
    }
}

/// Builds one static HTML page with inline CSS, readable straight from disk.
///
/// Figures are referenced by relative paths (put them in the same folder as the page), so the folder can be
/// zipped, copied or opened with `file://`. All text is escaped.
///
/// ```no_run
/// use pmon_report::{HtmlReport, TableCell};
/// let mut r = HtmlReport::new("pmon campaign");
/// r.heading("False alarms")
///     .paragraph("Rate per position uncertainty.")
///     .figure("false_alarm.svg", "False alarm rate (95 % CI).")
///     .table(&["sigma [m]", "rate", "paper"], &[vec![TableCell::num("0.1"), TableCell::num("0.002"), TableCell::pass("ok")]]);
/// r.write("out/report.html")?;
/// # Ok::<(), pmon_report::ReportError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HtmlReport {
    title: String,
    body: String,
}

const CSS: &str = r#"
:root { color-scheme: light; }
body { font-family: system-ui, -apple-system, "Segoe UI", "DejaVu Sans", Roboto, Helvetica, Arial, sans-serif;
  max-width: 62rem; margin: 2rem auto; padding: 0 1.2rem; line-height: 1.5; color: #1b1b1b; background: #fff; }
h1 { font-size: 1.7rem; border-bottom: 2px solid #333; padding-bottom: .3rem; }
h2 { font-size: 1.3rem; margin-top: 2.2rem; border-bottom: 1px solid #ccc; padding-bottom: .2rem; }
h3 { font-size: 1.1rem; margin-top: 1.6rem; }
p { margin: .6rem 0; }
table { border-collapse: collapse; margin: 1rem 0; font-size: .92rem; }
th, td { border: 1px solid #c8c8c8; padding: .3rem .6rem; text-align: left; vertical-align: top; }
th { background: #f0f0f0; font-weight: 600; }
tr:nth-child(even) td { background: #fafafa; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
td.pass, tr:nth-child(even) td.pass { background: #d9f2d9; color: #124d12; }
td.miss, tr:nth-child(even) td.miss { background: #f8d4d4; color: #7a1010; font-weight: 600; }
td.warn, tr:nth-child(even) td.warn { background: #fff1c2; color: #5c4500; }
td.muted { color: #888; }
figure { margin: 1.4rem 0; text-align: center; }
figure img { max-width: 100%; height: auto; border: 1px solid #e2e2e2; }
figcaption { font-size: .92rem; color: #444; margin-top: .4rem; }
figcaption a { font-size: .85rem; }
pre { background: #f6f6f6; border: 1px solid #ddd; padding: .7rem; overflow-x: auto; font-size: .85rem; line-height: 1.35; }
footer { margin-top: 3rem; font-size: .8rem; color: #888; }
"#;

impl HtmlReport {
    /// An empty report; the title is the page title and the top heading.
    pub fn new(title: impl Into<String>) -> Self {
        Self { title: title.into(), body: String::new() }
    }

    /// Adds a section heading (`<h2>`).
    pub fn heading(&mut self, text: &str) -> &mut Self {
        let _ = writeln!(self.body, "<h2>{}</h2>", escape_html(text));
        self
    }

    /// Adds a sub-section heading (`<h3>`).
    pub fn subheading(&mut self, text: &str) -> &mut Self {
        let _ = writeln!(self.body, "<h3>{}</h3>", escape_html(text));
        self
    }

    /// Adds a paragraph of plain text (escaped; line breaks are kept as spaces).
    pub fn paragraph(&mut self, text: &str) -> &mut Self {
        let _ = writeln!(self.body, "<p>{}</p>", escape_html(text));
        self
    }

    /// Adds a table. Rows shorter than the header are padded with empty cells; longer rows are kept whole.
    pub fn table<H: AsRef<str>>(&mut self, headers: &[H], rows: &[Vec<TableCell>]) -> &mut Self {
        let b = &mut self.body;
        b.push_str("<table>\n<thead><tr>");
        for h in headers {
            let _ = write!(b, "<th>{}</th>", escape_html(h.as_ref()));
        }
        b.push_str("</tr></thead>\n<tbody>\n");
        for row in rows {
            b.push_str("<tr>");
            for cell in row {
                match cell.class {
                    Some(c) => {
                        let _ = write!(b, "<td class=\"{}\">{}</td>", c.css(), escape_html(&cell.text));
                    }
                    None => {
                        let _ = write!(b, "<td>{}</td>", escape_html(&cell.text));
                    }
                }
            }
            for _ in row.len()..headers.len() {
                b.push_str("<td></td>");
            }
            b.push_str("</tr>\n");
        }
        b.push_str("</tbody>\n</table>\n");
        self
    }

    /// Adds a figure: an image (PNG or SVG) by relative path, with a caption; the image links to itself.
    pub fn figure(&mut self, src: &str, caption: &str) -> &mut Self {
        self.figure_inner(src, caption, None)
    }

    /// Adds a figure whose caption also links to its data file (e.g. the CSV written next to it).
    pub fn figure_with_data(&mut self, src: &str, caption: &str, data_href: &str) -> &mut Self {
        self.figure_inner(src, caption, Some(data_href))
    }

    fn figure_inner(&mut self, src: &str, caption: &str, data: Option<&str>) -> &mut Self {
        let src = escape_html(src);
        let cap = escape_html(caption);
        let _ =
            write!(self.body, "<figure>\n<a href=\"{src}\"><img src=\"{src}\" alt=\"{cap}\"></a>\n<figcaption>{cap}");
        if let Some(d) = data {
            let _ = write!(self.body, " <a href=\"{}\">[data]</a>", escape_html(d));
        }
        self.body.push_str("</figcaption>\n</figure>\n");
        self
    }

    /// Adds preformatted text (logs, parameter dumps), escaped.
    pub fn preformatted(&mut self, text: &str) -> &mut Self {
        let _ = writeln!(self.body, "<pre>{}</pre>", escape_html(text));
        self
    }

    /// The complete page.
    pub fn to_html(&self) -> String {
        let t = escape_html(&self.title);
        format!(
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
             <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<title>{t}</title>\n\
             <style>{CSS}</style>\n</head>\n<body>\n<h1>{t}</h1>\n{}<footer>Generated by pmon-report {}.</footer>\n\
             </body>\n</html>\n",
            self.body,
            env!("CARGO_PKG_VERSION"),
        )
    }

    /// Writes the page to `path` (its folder must exist); errors name the path.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<(), ReportError> {
        write_file(path.as_ref(), self.to_html().as_bytes())
    }
}
