//! The seeds file: `marker,u_px,v_px` and optionally `epoch`, one marker a line.

use crate::Error;
use std::path::Path;

/// One line of the seeds file.
#[derive(Debug, Clone, PartialEq)]
pub struct SeedLine {
    /// The marker's name.
    pub marker: String,
    /// Rough centre, column (pixels, COLMAP convention).
    pub u_px: f64,
    /// Rough centre, row (pixels).
    pub v_px: f64,
    /// The epoch the seed lies in (`None`: the first frame tracked).
    pub epoch: Option<String>,
    /// 1-based line in the file (the header is line 1).
    pub line: usize,
}

/// Reads and checks a seeds file: the header, numbers, no repeated or empty marker name.
///
/// # Errors
/// [`Error::Read`] when the file cannot be read, [`Error::Seeds`] naming the line otherwise.
pub fn read_seeds(path: &Path) -> Result<Vec<SeedLine>, Error> {
    let text = crashrig_input::file::read_text_limited(path, crashrig_input::file::MAX_CSV_BYTES)
        .map_err(|source| Error::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let bad = |line: usize, reason: String| Error::Seeds {
        path: path.to_path_buf(),
        line,
        reason,
    };
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(true)
        .from_reader(text.as_bytes());
    let headers = rdr
        .headers()
        .map_err(|e| bad(1, format!("not CSV: {e}")))?
        .clone();
    let col = |name: &str| headers.iter().position(|h| h == name);
    let (Some(im), Some(iu), Some(iv)) = (col("marker"), col("u_px"), col("v_px")) else {
        return Err(bad(
            1,
            "the header must name the columns marker,u_px,v_px (and optionally epoch)".into(),
        ));
    };
    let ie = col("epoch");
    let mut out: Vec<SeedLine> = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line() as usize);
            bad(line, format!("not CSV: {e}"))
        })?;
        let line = rec.position().map_or(0, |p| p.line() as usize);
        if rec.iter().all(str::is_empty) {
            continue;
        }
        if rec.len() != headers.len() {
            return Err(bad(
                line,
                format!("{} fields, the header has {}", rec.len(), headers.len()),
            ));
        }
        let marker = rec[im].to_string();
        if marker.is_empty() {
            return Err(bad(line, "empty marker name".into()));
        }
        let num = |i: usize, name: &str| -> Result<f64, Error> {
            rec[i]
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| bad(line, format!("{name} '{}' is not a finite number", &rec[i])))
        };
        let u_px = num(iu, "u_px")?;
        let v_px = num(iv, "v_px")?;
        if let Some(first) = out.iter().find(|s| s.marker == marker) {
            return Err(bad(
                line,
                format!("marker '{marker}' repeated (first on line {})", first.line),
            ));
        }
        let epoch = ie.map(|i| rec[i].to_string()).filter(|e| !e.is_empty());
        out.push(SeedLine {
            marker,
            u_px,
            v_px,
            epoch,
            line,
        });
    }
    if out.is_empty() {
        return Err(bad(1, "no seed in the file".into()));
    }
    Ok(out)
}
