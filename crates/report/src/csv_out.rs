//! CSV output, so every figure can ship its data.

use std::path::Path;

use crate::ReportError;

/// Writes a CSV file (RFC 4180 quoting, `\n` line ends) with one header row and the given rows.
///
/// Every row must have as many cells as `headers`; otherwise nothing useful is written and the error names the
/// file. Numbers are written as the caller formatted them.
///
/// ```no_run
/// pmon_report::write_csv("out/fig5.csv", &["sigma_m", "rate"], &[["0.1", "0.01"], ["0.2", "0.03"]])?;
/// # Ok::<(), pmon_report::ReportError>(())
/// ```
pub fn write_csv<H, R, C>(path: impl AsRef<Path>, headers: &[H], rows: &[R]) -> Result<(), ReportError>
where
    H: AsRef<str>,
    R: AsRef<[C]>,
    C: AsRef<str>,
{
    let path = path.as_ref();
    let csv_err = |source: csv::Error| ReportError::Csv { path: path.to_path_buf(), source };
    let mut w = csv::WriterBuilder::new().terminator(csv::Terminator::Any(b'\n')).from_path(path).map_err(csv_err)?;
    w.write_record(headers.iter().map(|h| h.as_ref())).map_err(csv_err)?;
    for row in rows {
        w.write_record(row.as_ref().iter().map(|c| c.as_ref())).map_err(csv_err)?;
    }
    w.flush().map_err(|source| ReportError::Io { path: path.to_path_buf(), source })?;
    Ok(())
}
