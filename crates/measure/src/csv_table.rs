//! The CSV inputs of `measure` (the observations, the scale bars): a bounded read of the file,
//! a header of named columns in any order, and every record with its line number. Each reader
//! checks its own fields; a problem anywhere is one [`Error::Csv`] naming the file and line.

use crate::Error;
use crashrig_input::file as input_file;
use std::path::Path;

/// An [`Error::Csv`] naming `path` and `line` (1 for the header or the file as a whole).
pub(crate) fn csv_error(path: &Path, line: u64, problem: impl Into<String>) -> Error {
    Error::Csv {
        path: path.to_path_buf(),
        line,
        problem: problem.into(),
    }
}

/// [`Error::NotUtf8`] of `path` at `at` (every text input of this crate reports it so).
pub(crate) fn not_utf8(path: &Path, at: input_file::NotUtf8) -> Error {
    Error::NotUtf8 {
        path: path.to_path_buf(),
        line: at.line,
        column: at.column,
    }
}

/// Reads the CSV file `path` (at most [`input_file::MAX_CSV_BYTES`]; a FIFO, device or
/// directory is refused before anything is read) whose header names exactly `columns`, in any
/// order, fields trimmed, and calls `row(line, fields)` for each record with its fields in the
/// order of `columns`. The first error — of the header, of a malformed record, or returned by
/// `row` — ends the read.
pub(crate) fn for_each_row<const N: usize>(
    path: &Path,
    columns: &[&str; N],
    mut row: impl FnMut(u64, [&str; N]) -> Result<(), Error>,
) -> Result<(), Error> {
    for_each_row_with(
        path,
        columns,
        &[],
        |_| Ok(()),
        |line, fields, []| row(line, fields),
    )
}

/// [`for_each_row`] with `optional` columns besides the required `columns`: the header names
/// every required column once and any of the optional ones at most once (nothing else);
/// `header(present)` is called with which optional columns the header holds (an `Err` is a
/// problem of line 1), and `row(line, fields, optional)` gets each optional column's field,
/// `None` where the header lacks the column.
pub(crate) fn for_each_row_with<const N: usize, const M: usize>(
    path: &Path,
    columns: &[&str; N],
    optional: &[&str; M],
    header: impl FnOnce([bool; M]) -> Result<(), String>,
    mut row: impl FnMut(u64, [&str; N], [Option<&str>; M]) -> Result<(), Error>,
) -> Result<(), Error> {
    let bytes =
        input_file::read_limited(path, input_file::MAX_CSV_BYTES).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
    // Located as every text input's: the line and column of the first byte that is not UTF-8.
    if let Err(e) = std::str::from_utf8(&bytes) {
        return Err(not_utf8(path, input_file::NotUtf8::of(&bytes, &e)));
    }
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(false)
        .from_reader(bytes.as_slice());
    let headers = reader
        .headers()
        .map_err(|e| csv_error(path, 1, format!("cannot read the header: {e}")))?;
    let (index, extra) =
        column_index(headers, columns, optional).map_err(|p| csv_error(path, 1, p))?;
    header(extra.map(|i| i.is_some())).map_err(|p| csv_error(path, 1, p))?;
    for record in reader.records() {
        let record = record.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            csv_error(path, line, format!("malformed CSV: {e}"))
        })?;
        let line = record.position().map_or(0, |p| p.line());
        row(
            line,
            index.map(|i| record.get(i).unwrap_or("")),
            extra.map(|i| i.map(|i| record.get(i).unwrap_or(""))),
        )?;
    }
    Ok(())
}

/// The position in `headers` of each of `columns` (each exactly once) and of each of
/// `optional` (at most once); nothing else.
fn column_index<const N: usize, const M: usize>(
    headers: &csv::StringRecord,
    columns: &[&str; N],
    optional: &[&str; M],
) -> Result<([usize; N], [Option<usize>; M]), String> {
    let mut index = [usize::MAX; N];
    let mut extra = [None; M];
    let mut all = columns.join(",");
    if M > 0 {
        all = format!("{all} and optionally {}", optional.join(","));
    }
    for (i, h) in headers.iter().enumerate() {
        if let Some(k) = columns.iter().position(|c| *c == h) {
            if index[k] != usize::MAX {
                return Err(format!("column `{h}` appears twice"));
            }
            index[k] = i;
        } else if let Some(k) = optional.iter().position(|c| *c == h) {
            if extra[k].is_some() {
                return Err(format!("column `{h}` appears twice"));
            }
            extra[k] = Some(i);
        } else {
            return Err(format!("unknown column `{h}` (the columns are {all})"));
        }
    }
    match index.iter().position(|&i| i == usize::MAX) {
        Some(k) => Err(format!(
            "missing column `{}` (the columns are {all})",
            columns[k]
        )),
        None => Ok((index, extra)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rows(text: &str) -> Result<Vec<(u64, [String; 2])>, String> {
        static NEXT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let k = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let dir =
            std::env::temp_dir().join(format!("crashrig-csv-table-{}-{k}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("table.csv");
        std::fs::write(&path, text).unwrap();
        let mut out = Vec::new();
        let r = for_each_row(&path, &["a", "b"], |line, [a, b]| {
            out.push((line, [a.to_string(), b.to_string()]));
            Ok(())
        });
        std::fs::remove_file(&path).unwrap();
        std::fs::remove_dir(&dir).unwrap();
        r.map(|()| out).map_err(|e| e.to_string())
    }

    #[test]
    fn fields_come_in_the_order_of_the_columns_with_their_lines() {
        let got = rows("b,a\n 2 ,1\n4,3\n").unwrap();
        assert_eq!(
            got,
            vec![
                (2, ["1".to_string(), "2".to_string()]),
                (3, ["3".to_string(), "4".to_string()])
            ]
        );
    }

    #[test]
    fn header_problems_name_line_1_and_the_column() {
        let e = rows("a,a\n1,2\n").unwrap_err();
        assert!(e.ends_with(":1: column `a` appears twice"), "{e}");
        let e = rows("a,c\n1,2\n").unwrap_err();
        assert!(
            e.ends_with(":1: unknown column `c` (the columns are a,b)"),
            "{e}"
        );
        let e = rows("a\n1\n").unwrap_err();
        assert!(
            e.ends_with(":1: missing column `b` (the columns are a,b)"),
            "{e}"
        );
    }

    #[test]
    fn a_record_with_the_wrong_field_count_names_its_line() {
        let e = rows("a,b\n1,2\n3\n").unwrap_err();
        assert!(e.contains(":3: malformed CSV"), "{e}");
    }
}
