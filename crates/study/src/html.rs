//! A self-contained HTML report: headings, paragraphs, tables and figures inlined as data URIs.
//!
//! No network, no external files: PNG figures are embedded as base64 `data:` URIs so the page
//! renders the same when mailed around. Every string is HTML-escaped.

use std::fmt::Write as _;

/// One block of the report, in reading order.
#[derive(Debug, Clone)]
pub enum Block {
    /// A section heading (`<h2>`).
    Heading(String),
    /// A paragraph of plain text.
    Paragraph(String),
    /// A bullet list.
    List(Vec<String>),
    /// A table.
    Table(Table),
    /// Several small PNG figures side by side (three per row), one caption each, and a caption
    /// for the group.
    Gallery {
        /// Caption of the group.
        caption: String,
        /// (caption, PNG bytes) of each figure.
        items: Vec<(String, Vec<u8>)>,
    },
    /// Trusted HTML written by this crate (inline SVG sketches); never user text.
    Raw(String),
    /// A PNG figure shown at full page width (at least 900 px on a normal screen), with a
    /// click-to-enlarge view at its natural size.
    Wide {
        /// Caption under the figure.
        caption: String,
        /// PNG bytes.
        png: Vec<u8>,
    },
    /// A PNG figure with a caption.
    Figure {
        /// Caption under the figure.
        caption: String,
        /// PNG bytes.
        png: Vec<u8>,
    },
}

/// A table with a caption, a header row and body rows (all plain text).
#[derive(Debug, Clone, Default)]
pub struct Table {
    /// Caption above the table.
    pub caption: String,
    /// Header cells.
    pub header: Vec<String>,
    /// Body rows.
    pub rows: Vec<Vec<String>>,
}

/// The report: a title and blocks.
#[derive(Debug, Clone, Default)]
pub struct Report {
    /// Page title and `<h1>`.
    pub title: String,
    /// Content in reading order.
    pub blocks: Vec<Block>,
}

impl Report {
    /// Appends a block.
    pub fn push(&mut self, b: Block) {
        self.blocks.push(b);
    }

    /// Renders the whole page.
    pub fn to_html(&self) -> String {
        let mut s = String::new();
        let _ = write!(
            s,
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{}</title>\n<style>{}</style>\n</head>\n<body>\n<h1>{}</h1>\n",
            escape(&self.title),
            CSS,
            escape(&self.title)
        );
        let mut wide = 0usize;
        for b in &self.blocks {
            match b {
                Block::Heading(h) => {
                    let _ = writeln!(s, "<h2>{}</h2>", escape(h));
                }
                Block::Paragraph(p) => {
                    let _ = writeln!(s, "<p>{}</p>", escape(p));
                }
                Block::List(items) => {
                    s.push_str("<ul>\n");
                    for i in items {
                        let _ = writeln!(s, "<li>{}</li>", escape(i));
                    }
                    s.push_str("</ul>\n");
                }
                Block::Table(t) => {
                    let _ = writeln!(s, "<table>\n<caption>{}</caption>", escape(&t.caption));
                    s.push_str("<thead><tr>");
                    for h in &t.header {
                        let _ = write!(s, "<th>{}</th>", escape(h));
                    }
                    s.push_str("</tr></thead>\n<tbody>\n");
                    for r in &t.rows {
                        s.push_str("<tr>");
                        for c in r {
                            let _ = write!(s, "<td>{}</td>", escape(c));
                        }
                        s.push_str("</tr>\n");
                    }
                    s.push_str("</tbody>\n</table>\n");
                }
                Block::Gallery { caption, items } => {
                    let _ = writeln!(
                        s,
                        "<div class=\"gallery\"><p class=\"gcap\">{}</p>",
                        escape(caption)
                    );
                    for (c, png) in items {
                        let _ = writeln!(
                            s,
                            "<figure><img alt=\"{}\" src=\"data:image/png;base64,{}\"><figcaption>{}</figcaption></figure>",
                            escape(c),
                            base64(png),
                            escape(c)
                        );
                    }
                    s.push_str("</div>\n");
                }
                Block::Raw(h) => {
                    s.push_str(h);
                    s.push('\n');
                }
                Block::Wide { caption, png } => {
                    wide += 1;
                    let data = base64(png);
                    let _ = writeln!(
                        s,
                        "<figure class=\"wide\"><a href=\"#zoom{wide}\"><img alt=\"{}\" src=\"data:image/png;base64,{data}\"></a><figcaption>{} (click to enlarge)</figcaption></figure>\n<a class=\"zoom\" id=\"zoom{wide}\" href=\"#_\"><img alt=\"{} (enlarged)\" src=\"data:image/png;base64,{data}\"></a>",
                        escape(caption),
                        escape(caption),
                        escape(caption)
                    );
                }
                Block::Figure { caption, png } => {
                    let _ = writeln!(
                        s,
                        "<figure><img alt=\"{}\" src=\"data:image/png;base64,{}\"><figcaption>{}</figcaption></figure>",
                        escape(caption),
                        base64(png),
                        escape(caption)
                    );
                }
            }
        }
        s.push_str(CHECK_SCRIPT);
        s.push_str("</body>\n</html>\n");
        s
    }
}

const CSS: &str = "body{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}\
table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:.25em .6em;text-align:right}\
th{background:#eee}caption{font-weight:bold;text-align:left;padding:.3em 0}\
figure{margin:1.5em 0}img{max-width:100%;border:1px solid #ddd}figcaption{font-size:.9em;color:#555}\
.gallery{display:flex;flex-wrap:wrap;gap:1%}.gallery figure{width:32%;margin:.5em 0}.gcap{width:100%;font-weight:bold;margin:.5em 0 0}\
figure.wide img{width:100%;min-width:900px}.zoom{display:none}.zoom:target{display:flex;position:fixed;inset:0;\
background:rgba(0,0,0,.85);align-items:center;justify-content:center;z-index:9;overflow:auto}\
.zoom:target img{max-width:none;width:auto;border:0}.verdict td:first-child{text-align:left}\
td.l{text-align:left}.note{background:#fff8e0;border-left:4px solid #e0b000;padding:.4em .8em}";

/// Marks `<body data-images="ok:N">` once every image decoded, or `"broken:K/N"`, and
/// `data-wide-min-px` = the rendered width of the narrowest full-width figure (−1: none); read by
/// `cargo xtask report-check` through headless Chromium. It runs locally and loads nothing.
const CHECK_SCRIPT: &str = "<script>window.addEventListener('load',function(){var i=document.images,b=0;\
for(var k=0;k<i.length;k++){if(!i[k].complete||i[k].naturalWidth===0){b++;}}\
document.body.setAttribute('data-images',b===0?'ok:'+i.length:'broken:'+b+'/'+i.length);\
var w=document.querySelectorAll('figure.wide img'),m=-1;for(var k=0;k<w.length;k++){var c=w[k].getBoundingClientRect().width;if(m<0||c<m){m=c;}}\
document.body.setAttribute('data-wide-min-px',String(Math.round(m)));});</script>\n";

/// Escapes text for HTML element content and attribute values.
pub fn escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            _ => o.push(c),
        }
    }
    o
}

/// Standard base64 (RFC 4648, with padding).
pub fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut o = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        o.push(A[(n >> 18) as usize & 63] as char);
        o.push(A[(n >> 12) as usize & 63] as char);
        o.push(if chunk.len() > 1 {
            A[(n >> 6) as usize & 63] as char
        } else {
            '='
        });
        o.push(if chunk.len() > 2 {
            A[n as usize & 63] as char
        } else {
            '='
        });
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_rfc4648_vectors() {
        // RFC 4648 §10 test vectors.
        let cases = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ];
        for (i, o) in cases {
            assert_eq!(base64(i.as_bytes()), o, "input {i:?}");
        }
    }

    #[test]
    fn escape_nominal() {
        assert_eq!(
            escape(r#"<a href="x">&'"#),
            "&lt;a href=&quot;x&quot;&gt;&amp;&#39;"
        );
    }

    #[test]
    fn report_renders_every_block() {
        let mut r = Report {
            title: "T <1>".into(),
            ..Default::default()
        };
        r.push(Block::Heading("H".into()));
        r.push(Block::Paragraph("p & q".into()));
        r.push(Block::List(vec!["a".into()]));
        r.push(Block::Table(Table {
            caption: "c".into(),
            header: vec!["x".into()],
            rows: vec![vec!["1".into()]],
        }));
        r.push(Block::Figure {
            caption: "f".into(),
            png: vec![1, 2, 3],
        });
        r.push(Block::Gallery {
            caption: "g".into(),
            items: vec![("i".into(), vec![0xff])],
        });
        let h = r.to_html();
        assert!(h.contains("<title>T &lt;1&gt;</title>"));
        assert!(h.contains("<p>p &amp; q</p>"));
        assert!(h.contains("<td>1</td>"));
        assert!(h.contains("data:image/png;base64,AQID"));
        assert!(h.contains("class=\"gallery\"") && h.contains("data:image/png;base64,/w=="));
        assert!(h.trim_end().ends_with("</html>"));
    }
}
